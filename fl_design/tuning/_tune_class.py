"""A design for a whole plant class, certified for every member: ``fl.tune(plant_class)``.

A rig owner knows ``rho``, ``T``, the sign and range of ``b``, the sensor noise and the input
limits (:class:`fl_design.PlantClass`), not a model. Each number comes from those facts:

1. **gamma**: the dynamic law ``u+ = u + gamma (v - sigmahat)`` makes ``u`` follow the input it
   needs at the rate ``1 - |gamma b|`` per sample; the paper asks ``|gamma| < 1/|b|_max``. The
   candidates put ``c = |gamma| |b|_max`` at 0.5, 0.25 and 0.1 (sign of ``b``): the larger,
   the faster ``u`` catches up at the small end of ``b`` (rate ``c |b|_min / (|b|_max T)``),
   the faster the observer must be at the large end; when none of them is certified with its
   member runs converging, slower ones at 0.03 and 0.01 (a larger eps*, less noise in ``u``);
2. **loop decay** ``d``: a fifth of that slowest inner rate (the loop must be slower than the
   input catching up, the certified lower bound of :func:`fl_design.certify_gamma`), at most
   ``0.05 / T``; **gains** :func:`fl_design.synthesize_gains` at ``d`` (decay certified);
3. **eps**: a quarter of the class's frozen-``b`` eps* (an eigenvalue scan over ``b``'s range
   and ``a``'s slope box, :func:`fl_design.eps_star_curve`), certified for the class by
   :func:`fl_design.certify_eps` (``b`` varying arbitrarily unless the class bounds its rate);
4. **objective**: ``"least-noise"`` ranks the candidates by the class's noise gain (rms ``u``
   per rms sensor noise, the worse end of ``b``, at that eps), ``"fastest"`` by ``d``; the
   first candidate in that order whose eps is certified is chosen; then a larger eps (less
   noise) up to half the frozen eps* is searched by bisection on the fraction
   (:data:`UPGRADE_STEPS` certificates within :data:`UPGRADE_BUDGET` s of CPU), the largest
   certified kept (no candidate certified: the best stays, NOT certified, said);
5. **checked**: margins at the plant input at both ends of ``b``, the noise gain, and runs on
   class members in the virtual rig (:mod:`fl_design.tuning._class_checks`).

Examples
--------
>>> import fl_design as fl
>>> cls = fl.PlantClass(rho=2, T=1e-3, b=(2.0, 8.0), noise_std=1e-3, u_limits=(-10, 10))
>>> tuned = fl.tune(cls, reference=1.0)
>>> tuned.certified, all(m.converged for m in tuned.members)
(True, True)
"""

from __future__ import annotations

import math
import time

from .. import _validate as V
from ..analysis import certify_eps, eps_star_curve, synthesize_gains
from ..analysis._plant_class import PlantClass
from ..design import EHGO, Design, DynamicController
from ..errors import NoDesignError, ParameterError
from ._check import step_target
from ._class_checks import class_margins, member_runs, surrogate_noise_gain
from ._class_tuning import ClassTuning

#: |gamma| |b|_max of the candidates (the paper's bound is 1).
GAMMA_FRACTIONS = (0.5, 0.25, 0.1)
#: Slower candidates, tried only when none of :data:`GAMMA_FRACTIONS` is certified with every
#: member run converging: a smaller gamma lets the loop be slower and the observer's eps* larger,
#: so the sensor noise reaching u falls (~ 1/eps^rho) - the way out when the noise saturates u
#: (e.g. rho = 3, b in [20, 200], T = 0.5 ms, noise 1e-4: noise gain 9.4e4 at c = 0.1, 29 at
#: c = 0.01).
SLOW_FRACTIONS = (0.03, 0.01)
#: The loop decay is the slowest inner rate divided by this.
INNER_OVER_LOOP = 5.0
#: eps is first tried at this fraction of the class's frozen eps*, then at the bolder one.
SAFE_FRACTION, BOLD_FRACTION = 0.25, 0.5
#: Bisection steps on the fraction between them, within this CPU time [s].
UPGRADE_STEPS, UPGRADE_BUDGET = 3, 3.0


def _objective(objective) -> str:
    if objective in ("least-noise", "least_noise", "fastest"):
        return objective.replace("_", "-")
    raise ParameterError(f"objective={objective!r}: a plant class takes 'least-noise' or "
                         "'fastest'")


def _reference(cls: PlantClass, reference) -> float:
    if reference is not None:
        return V.real_scalar("reference", reference)
    y0 = 0.0 if cls.operating_point is None else cls.operating_point
    if cls.y_range is not None:
        return step_target(y0, cls.y_range)
    return float(y0 + 1.0)


def _candidate(cls: PlantClass, c: float, u_lim) -> dict:
    """One loop: gamma = sign c / |b|_max, decay, gains, frozen eps*, noise gain at eps*/4."""
    T, sign = float(cls.T), cls.sign
    bmin, bmax = sorted(abs(b) for b in cls.b)
    gamma = sign * c / bmax
    inner = c * bmin / (bmax * T)
    d = min(inner / INNER_OVER_LOOP, 0.05 / T)
    syn = synthesize_gains(cls.rho, decay=d)
    probe = Design(estimator=EHGO(rho=cls.rho, eps=max(0.2 / d, 2 * T), T=T),
                   controller=DynamicController(syn.gains, gamma, u_limits=u_lim))
    curve = eps_star_curve(probe, cls.b, [abs(gamma)], a_jacobian_bounds=cls.a_slopes,
                           eps_range=(T / 4.0, max(10.0 / d, 20.0 * T)), certified=False)
    frozen = float(curve.eps_star_frozen[0])
    out = {"c": c, "gamma": gamma, "inner": inner, "decay": d, "gains": syn, "frozen": frozen}
    if not math.isfinite(frozen) or frozen <= 0:
        out.update(design=None, noise=math.inf)
        return out
    design = probe.replace(eps=frozen)
    ng = [surrogate_noise_gain(design.replace(eps=frozen * SAFE_FRACTION), b) for b in cls.b]
    out.update(design=design, noise=max(g["u"] for g in ng), noise_y=max(g["y"] for g in ng))
    return out


def _delay_words(cls: PlantClass, margins) -> tuple[str, ...]:
    """The class's input delay against the loop's delay margins (the certificate does not
    cover a delay; the margins and the member runs, which include it, are the evidence)."""
    if not cls.delay:
        return ()
    delay, worst = cls.delay * float(cls.T), min(margins, key=lambda m: m.delay_margin)
    verdict = ("within" if delay < worst.delay_margin else
               "BEYOND (the frozen loop with this delay may be unstable)")
    words = (f"input delay {cls.delay} samples = {delay:.4g} s, {verdict} the smallest delay "
             f"margin {worst.delay_margin:.3g} s (b = {worst.b:.4g}); not covered by the "
             "certificate")
    return (words,)


def _certified(cand, cls, tried):
    """``(candidate with its eps, certificate, why)`` at the largest certified fraction of the
    class's frozen eps* tried (a quarter first, then up to :data:`BOLD_FRACTION` within
    :data:`UPGRADE_BUDGET`), or None (the reason appended to ``tried``)."""
    trial = cand["design"].replace(eps=cand["frozen"] * SAFE_FRACTION)
    ec = certify_eps(trial, cls, search=False)
    if not ec.certified:
        tried.append(f"|gamma| |b|_max = {cand['c']:g}, eps = {trial.estimator.eps:.4g} s: "
                     f"not certified ({ec.reason})")
        return None
    chosen, cert = dict(cand, design=trial), ec
    why = (f"eps = {trial.estimator.eps:.4g} s ({SAFE_FRACTION:g} x the class's "
           f"frozen-b eps* {cand['frozen']:.4g} s; certified for {ec.covers} b)")
    lo, hi, cpu0 = SAFE_FRACTION, BOLD_FRACTION, time.process_time()
    for step in range(UPGRADE_STEPS):  # larger eps (less noise) while certified: bisection
        if time.process_time() - cpu0 > UPGRADE_BUDGET:
            break
        f = BOLD_FRACTION if step == 0 else math.sqrt(lo * hi)
        trial = chosen["design"].replace(eps=chosen["frozen"] * f)
        ec = certify_eps(trial, cls, search=False)
        if ec.certified:
            lo, chosen, cert = f, dict(chosen, design=trial), ec
            why = (f"eps = {trial.estimator.eps:.4g} s ({f:.3g} x the class's frozen-b eps* "
                   f"{chosen['frozen']:.4g} s, the largest fraction certified of those tried; "
                   f"certified for {ec.covers} b)")
            if f == BOLD_FRACTION:
                break
        else:
            hi = f
            tried.append(f"|gamma| |b|_max = {chosen['c']:g}, eps = "
                         f"{trial.estimator.eps:.4g} s: not certified ({ec.reason})")
    return chosen, cert, why


def tune_class(cls: PlantClass, *, T: float | None = None, objective="least-noise",
               reference=None, u_limits=None, members: bool = True,
               seed: int = 0, progress=None) -> ClassTuning:
    """A design certified for every plant of ``cls`` (the module says how).

    Parameters
    ----------
    cls : PlantClass
        The class (its ``T``, or ``T`` given here, is required).
    T : float, optional
        The sampling time, for a class without one (must agree with the class's).
    objective : str, optional
        ``"least-noise"`` (default) or ``"fastest"``.
    reference : float, optional
        Step target of the member runs (default the operating point plus 5 % of ``y_range``,
        else plus 1).
    u_limits : (float, float), optional
        Input saturation (default the class's ``u_limits``).
    members : bool, optional
        Run the class members (default True).
    seed : int, optional
        Noise and switching seed of the member runs.
    progress : callable, optional
        ``progress(line)`` before each step (a candidate's eps* scan, a certificate, the
        member runs), the line saying which; ``fl.tune(cls)`` prints them on stderr with the
        seconds so far (:class:`fl_design._progress.Lines`), ``fl-design run`` with its stage
        lines.

    Returns
    -------
    ClassTuning

    Raises
    ------
    ParameterError
        A class without ``T``, a bad objective or reference.
    NoDesignError
        No candidate has a stable eps for the class.

    Examples
    --------
    See the module.
    """
    V.instance("plant_class", cls, PlantClass, "an fl.PlantClass")
    if T is not None:
        cls = cls.with_T(V.positive("T", T))
    if cls.T is None:
        raise ParameterError("the class has no T: give PlantClass(..., T=...) (the sampling "
                             "time of the rig) to design for it")
    kind = _objective(objective)
    r = _reference(cls, reference)
    u_lim = cls.u_limits if u_limits is None else V.interval("u_limits", u_limits)
    start = time.perf_counter()

    def say(text: str) -> None:
        if progress is not None:
            progress(text)

    cands, tried = [], []
    chosen = cert = None
    eps_why, runs, first = "", (), None
    key = (lambda x: x["noise"]) if kind == "least-noise" else (lambda x: -x["decay"])
    for tier in (GAMMA_FRACTIONS, SLOW_FRACTIONS):
        if tier is SLOW_FRACTIONS:
            say(f"no candidate certified with its members converging: slower ones, "
                f"|gamma| |b|_max = {', '.join(f'{c:g}' for c in tier)}")
        tier_cands = []
        for i, c in enumerate(tier):
            say(f"candidate {i + 1}/{len(tier)}, |gamma| |b|_max = {c:g}: frozen-b eps* scan")
            cand = _candidate(cls, c, u_lim)
            if cand["design"] is None:
                tried.append(f"|gamma| |b|_max = {c:g}: no stable eps for the class (frozen-b "
                             "eps* scan empty)")
                continue
            tier_cands.append(cand)
        cands += tier_cands
        for cand in sorted(tier_cands, key=key):  # the first certified whose members converge
            say(f"|gamma| |b|_max = {cand['c']:g}: the class certificate at "
                f"{SAFE_FRACTION:g}-{BOLD_FRACTION:g} x eps* {cand['frozen']:.4g} s")
            got = _certified(cand, cls, tried)
            if got is None:
                continue
            cand_c, cert_c, why_c = got
            if members:
                say(f"|gamma| |b|_max = {cand['c']:g}: member runs "
                    f"({12.0 / cand_c['decay']:.3g} s each)")
            runs_c = (member_runs(cand_c["design"], cls, r, 12.0 / cand_c["decay"], seed=seed)
                      if members else ())
            if first is None:
                first = (cand_c, cert_c, why_c, runs_c)
            if all(m.converged for m in runs_c):
                chosen, cert, eps_why, runs = cand_c, cert_c, why_c, runs_c
                break
            tried.append(f"|gamma| |b|_max = {cand_c['c']:g}, eps = "
                         f"{cand_c['design'].estimator.eps:.4g} s: certified, but "
                         f"{sum(not m.converged for m in runs_c)}/{len(runs_c)} member runs do "
                         "not converge (noise and input limits are outside the certificate)")
        if chosen is not None:
            break
    if not cands:
        raise NoDesignError(f"no design for the class ({cls.describe()}): " + "; ".join(tried))
    cands.sort(key=key)
    if chosen is None and first is not None:  # none whose members converge: the first, said
        chosen, cert, eps_why, runs = first
    if chosen is None:
        chosen = dict(cands[0], design=cands[0]["design"].replace(
            eps=cands[0]["frozen"] * SAFE_FRACTION))
        cert = certify_eps(chosen["design"], cls, search=False)
        eps_why = (f"eps = {chosen['design'].estimator.eps:.4g} s ({SAFE_FRACTION:g} x the "
                   f"class's frozen-b eps* {chosen['frozen']:.4g} s); NOT certified for the "
                   f"class there: {cert.reason}")
        runs = (member_runs(chosen["design"], cls, r, 12.0 / chosen["decay"], seed=seed)
                if members else ())
    design = chosen["design"]
    ng = {f"{b:.6g}": surrogate_noise_gain(design, b) for b in cls.b}
    margins = class_margins(design, cls)
    bmin, bmax = sorted(abs(b) for b in cls.b)
    reasons = (
        f"class: {cls.describe()}",
        (f"gamma = {chosen['gamma']:.4g} (|gamma| |b|_max = {chosen['c']:g}, paper bound "
         f"1/|b|_max = {1 / bmax:.4g}; u catches up at >= {chosen['inner']:.3g} rad/s for "
         f"|b| = {bmin:g})"),
        (f"gains {tuple(round(k, 6) for k in chosen['gains'].gains)} (synthesize_gains at decay "
         f"{chosen['decay']:.4g} rad/s, 1/{INNER_OVER_LOOP:g} of that inner rate)"),
        eps_why,
        (f"noise gain {max(g['u'] for g in ng.values()):.4g} rms u per rms sensor noise (worse "
         f"end of b; rms y {max(g['y'] for g in ng.values()):.3g} per rms noise)"),
        *(f"margins at b = {m.b:.4g}: gain ({m.gain_margins[0]:.3g}, {m.gain_margins[1]:.3g}), "
          f"phase {m.phase_margin:.3g} deg, delay {m.delay_margin:.3g} s" for m in margins),
        *_delay_words(cls, margins),
        (f"members: {sum(m.converged for m in runs)}/{len(runs)} runs converge"
         if runs else "members: not run"),
        (f"chosen: {kind}: {len(cands)} candidate loop(s) ranked by "
        f"{'noise gain' if kind == 'least-noise' else 'decay'}"),
        f"tuned in {time.perf_counter() - start:.1f} s")
    return ClassTuning(design=design, plant_class=cls, objective=kind, reference=r,
                       time_scale=chosen["decay"], eps_certificate=cert,
                       eps_star_frozen=chosen["frozen"], noise_gain=ng, margins=margins,
                       members=runs, reasons=reasons, tried=tuple(tried),
                       uncovered=cls.uncovered())


__all__ = ["ClassTuning", "PlantClass", "tune_class"]
