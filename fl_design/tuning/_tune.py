"""A design proposed from the plant alone, with its certificates: :func:`tune`.

The paper tunes on hardware ("reduce eps by an order of 10 until stable"); here each number
comes from the plant, the certificates and a check, and is said with its reason:

1. **time scale** ``d``: the largest ``|eigenvalue|`` of the plant linearized at its operating
   point (at least 1 rad/s), at most the rate at which a fifth of the input's room (from
   ``u_eq`` to the nearer limit) moves the step through ``y^(rho) = b u``, i.e.
   ``(0.2 |b|_min room / |step|)^(1/rho)``;
2. **T** (unless given): 100 samples per ``1/d``, rounded down to 1-2-5;
3. **gains**: :func:`fl_design.synthesize_gains` at decay ``d`` (all poles at
   ``-(1 + spare) d``, the decay certified);
4. **gamma** (sign of ``b``), inside the admissible interval of :func:`fl_design.certify_gamma`
   at a probe eps (a factor 2 from its lower end, 1.25 from its upper end where it can; the
   probe eps from ``0.2 / d`` down by 4 until some gamma is stable): rule ``"fast"``, the disturbance estimate ``5x`` the
   loop's rate for the smallest ``|b|``, ``5 d T / |b|_min``; rule ``"low"``, twice the larger of the certified lower
   bound (below it no eps works) and the interval's lower end (the smaller gamma, the larger
   eps* and the less noise);
5. **eps**: a provisional eps, half the smaller of the surrogate's frozen-b eps* (eigenvalue
   scan, :func:`fl_design.eps_star_curve`) and the real plant's linearized eps*
   (:func:`fl_design.linearized_eps_star`, which sees ``a(x)``, e.g. an unstable pole), ranks
   the candidates; the chosen one gets the largest eps with a certified margin: the smaller
   of the certified eps* (varying ``b``, :func:`fl_design.certify_eps`) and the linearized
   eps*, over :data:`EPS_MARGIN` = 1.25, certified again at the design (a certified eps* is
   not an interval). When no LMI certifies the provisional eps, nor its half or quarter, the
   design stays uncertified and ``Tuning.certified`` and the reasons say so;
6. **checked** by a simulation of the step (nonlinear plant, input limits), a short sweep
   around the design (eps ``/2, x1``, gamma ``/2, x1, x2``) and its noise gain
   (:func:`fl_design.analysis.noise_gain`).

Objectives: ``"least-noise"`` (DESIGN.md's spelling; ``"least_noise"`` too: loops at ``d``,
``d/2``, ``d/4`` with the low gamma, the least noise gain wins), ``"fastest"`` (loops at
``d``, ``2 d``, ``4 d`` up to what the whole input room allows, the fast gamma, the shortest
settling time wins), ``("overshoot", x)`` (the loop at ``d`` with the fast gamma and the
three low-gamma loops: the least noise gain with an overshoot of at most ``x``, a fraction).
A candidate whose gamma interval or eps* is empty, or whose check does not converge, is said
in ``tried``; when none is left :class:`~fl_design.errors.NoDesignError` says why, per
candidate.

Examples
--------
>>> import fl_design as fl
>>> tuned = fl.tune(fl.plants.pendulum(), reference=0.1, decays=[1])
>>> tuned.certified, tuned.status, tuned.design.estimator.T
(True, 'converged', 0.002)
"""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as V
from ..analysis import (
    certify_eps,
    certify_gamma,
    eps_star_curve,
    linearized_eps_star,
    synthesize_gains,
)
from ..design import EHGO, Design, DynamicController
from ..errors import NoDesignError, ParameterError, RelativeDegreeError
from ..symbolic import Plant
from ._check import baseline_for, check_candidate
from ._tune_class import PlantClass, tune_class
from ._tuning import Tuning

#: Candidates per objective: (loop decay over the plant's time scale, gamma rule); "fast":
#: the disturbance estimate 5x the loop's rate, "low": near the certified lower bound.
CANDIDATES = {"least-noise": ((1.0, "low"), (0.5, "low"), (0.25, "low")),
              "fastest": ((1.0, "fast"), (2.0, "fast"), (4.0, "fast")),
              "overshoot": ((1.0, "fast"), (1.0, "low"), (0.5, "low"), (0.25, "low"))}
#: eps is the certified eps* divided by this (the certified margin).
EPS_MARGIN = 1.25


def nice_time(x: float) -> float:
    """``x`` rounded down to 1, 2 or 5 times a power of ten.

    Examples
    --------
    >>> nice_time(0.0041), nice_time(0.0099), nice_time(0.3)
    (0.002, 0.005, 0.2)
    """
    e = math.floor(math.log10(x))
    m = x / 10 ** e
    return float(f"{(5 if m >= 5 else 2 if m >= 2 else 1) * 10 ** e:.3g}")


def _objective(objective) -> tuple[str, float | None]:
    if objective in ("least-noise", "least_noise", "fastest"):  # DESIGN.md spells least-noise
        return objective.replace("_", "-"), None
    if (isinstance(objective, tuple) and len(objective) == 2 and objective[0] == "overshoot"):
        x = V.positive("overshoot limit", objective[1])
        return "overshoot", float(x)
    raise ParameterError(f"objective={objective!r}: give 'least-noise', 'fastest' or "
                         "('overshoot', x) with x the largest overshoot as a fraction (0.1 = 10 %)")


def _reference(plant, reference, y_op) -> float:
    if reference is not None:
        return V.real_scalar("reference", reference)
    out = plant.output
    if plant.region is not None and out in plant.region:
        lo, hi = plant.region[out]
        step = 0.05 * (hi - lo)
        return float(y_op + step if y_op + step <= hi else y_op - step)
    raise ParameterError("reference is needed: the output is not a state with a range in the "
                         "plant's region; give reference=... (the step target, absolute)")


def _b_range(plant) -> tuple[float, float]:
    if plant.region is None or plant.input_range is None:
        raise NoDesignError(f"no design for {plant.name!r}: the plant declares no "
                            f"{'region' if plant.region is None else 'input_range'}, so the "
                            "b-range that sizes gamma is unknown; give Plant(region=..., "
                            "input_range=...)")
    try:
        lo, hi = plant.b_bounds(allow_sign_change=True)
    except (ParameterError, RelativeDegreeError) as exc:
        raise NoDesignError(f"no design for {plant.name!r}: {exc}") from exc
    if lo * hi <= 0:
        raise NoDesignError(f"no design for {plant.name!r}: b changes sign on the region (b in "
                            f"[{lo:.4g}, {hi:.4g}]); the method needs the sign of b: shrink the "
                            "region")
    return float(lo), float(hi)


def tune(plant: Plant, *, T: float | None = None, objective="least-noise",
         reference: float | None = None, u_limits=None, decays=None,
         baseline="auto") -> Tuning:
    """Propose a certified, checked design for ``plant`` (the module says how and why).

    Parameters
    ----------
    plant : Plant
        A plant with a ``region`` and an ``input_range`` (they give the b-range).
    T : float, optional
        Sampling time (default from the plant's time scale and the actuator, step 2).
    objective : str or tuple, optional
        ``"least-noise"`` (default; ``"least_noise"`` too), ``"fastest"`` or
        ``("overshoot", x)``, ``x`` a fraction.
    reference : float, optional
        The step target of the checks (default the operating output plus 5 % of the output's
        range in the region).
    u_limits : (float, float), optional
        Input saturation (default the plant's ``input_range``); must contain ``u_eq``.
    decays : sequence of float, optional
        The loop decays to try, as factors of the plant's time scale (default per objective:
        ``(1, 1/2, 1/4)``, fastest ``(1, 2, 4)``); each costs certificates and checks.
    baseline : Design, None or "auto", optional
        A design to compare noise and overshoot with; ``"auto"`` (default): the paper's design
        for the library TRMS (:func:`fl_design.presets.paper_design`), else none.

    Returns
    -------
    Tuning

    Raises
    ------
    ParameterError
        A bad ``T``, ``objective``, ``reference``, ``u_limits`` or ``baseline``.
    NoDesignError
        No region or input range, ``b`` changing sign, ``u_eq`` outside the limits, or no
        candidate with a nonempty gamma interval, a certified eps and a converging check (the
        message says, per candidate, why).

    Examples
    --------
    >>> import fl_design as fl
    >>> tuned = fl.tune(fl.plants.pendulum(), reference=0.1, objective="fastest", decays=[1])
    >>> tuned.certified, tuned.status, [round(k, 4) for k in tuned.design.controller.gains]
    (True, 'converged', [10.2063, 6.3895])
    """
    if isinstance(plant, PlantClass):  # what a rig owner knows: designed for every member
        return tune_class(plant, T=T, objective=objective, reference=reference, u_limits=u_limits)
    V.instance("plant", plant, Plant, "an fl.Plant (fl.Plant.from_ode or fl.plants.*)")
    kind, limit = _objective(objective)
    if not (baseline is None or isinstance(baseline, Design) or
            (isinstance(baseline, str) and baseline == "auto")):
        raise ParameterError(f"baseline={baseline!r}: give a Design, None or 'auto'")
    rho = plant.relative_degree()
    lo, hi = _b_range(plant)
    u_lim = tuple(plant.input_range) if u_limits is None else V.interval("u_limits", u_limits)
    if not u_lim[0] < plant.u_eq < u_lim[1]:
        raise NoDesignError(f"no design for {plant.name!r}: the equilibrium input u_eq = "
                            f"{plant.u_eq:.6g} is not inside u_limits {u_lim}: no room to act")
    y_op = float(plant.casadi().h(plant.x_op))
    r = _reference(plant, reference, y_op)
    A = np.asarray(plant.linearization()[0], dtype=float)
    speed = float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0
    step, room = abs(r - y_op), min(plant.u_eq - u_lim[0], u_lim[1] - plant.u_eq)
    reach = (0.2 * min(abs(lo), abs(hi)) * room / step) ** (1.0 / rho) if step > 0 else math.inf
    decay = max(0.01, min(max(1.0, speed), reach))
    if T is None:
        T, T_why = (min(0.1, max(1e-4, nice_time(1.0 / (100.0 * decay)))),
                    "100 samples per 1/time scale, 1-2-5 rounded")
    else:
        T, T_why = V.positive("T", T), "given"
    head = [(f"time scale {decay:.3g} rad/s (largest |eigenvalue| of the linearization "
             f"{speed:.3g}, at least 1; at most {reach:.3g}, what a fifth of the input's room "
             f"{room:.3g} moves the step {step:.3g} at)"), f"T = {T:g} s ({T_why})"]
    loop = _Setup(plant, rho, T, (lo, hi), u_lim, r)
    full_reach = reach * 5.0 ** (1.0 / rho)
    chosen, tried = [], []
    cands = CANDIDATES[kind]
    if decays is not None:
        factors = [V.positive("decays entry", f) for f in V.real_vector("decays", decays)]
        if not factors:
            raise ParameterError("decays is empty: give factors of the time scale, e.g. (1.0,)")
        rules = {rule for _, rule in cands}
        cands = [(f, rule) for f in factors for rule in sorted(rules)]
    for f, rule in cands:
        d = decay * f
        if d > full_reach * (1 + 1e-12) or d < 0.01:
            tried.append(f"loop at {d:.3g} rad/s: outside [0.01, {full_reach:.3g}] (the whole "
                         "input room)")
            continue
        cand = _candidate(loop, d, rule, tried)
        if cand is None:
            continue
        if kind == "overshoot" and not cand["overshoot"] <= 100.0 * limit:
            tried.append(f"loop at {d:.3g} rad/s, gamma {cand['design'].controller.gamma:.3g}: "
                         f"overshoot {cand['overshoot']:.3g} % > {100 * limit:g} %")
            continue
        chosen.append(cand)
    if not chosen:
        raise NoDesignError(f"no design for {plant.name!r} ({kind}): " + "; ".join(tried))
    key = ((lambda c: c["settling_time"]) if kind == "fastest" else (lambda c: c["noise_gain"]))
    best = min(chosen, key=key)
    why = {"least-noise": f"the least noise gain of {len(chosen)} converging loops",
           "fastest": f"the shortest settling time of {len(chosen)} converging loops",
           "overshoot": (f"the least noise gain of {len(chosen)} converging loops with overshoot "
                         f"<= {100 * (limit or 0):g} %")}[kind]
    others = [f"also: loop at {c['decay']:.3g} rad/s, gamma {c['design'].controller.gamma:.3g}, "
              f"eps {c['design'].estimator.eps:.3g}: noise gain {c['noise_gain']:.3g}, "
              f"settling {c['settling_time']:.3g} s, overshoot {c['overshoot']:.3g} %"
              for c in chosen if c is not best]
    return _result(loop, best, kind if kind != "overshoot" else f"overshoot <= {100 * limit:g} %",
                   head, why, tuple(tried + others), baseline)


class _Setup:
    """What every candidate shares: plant, T, b-range, limits, reference."""

    def __init__(self, plant, rho, T, b_bounds, u_lim, r):
        self.plant, self.rho, self.T, self.b_bounds, self.u_lim, self.r = (
            plant, rho, T, b_bounds, u_lim, r)
        self.sign = math.copysign(1.0, b_bounds[0])
        self.bmax = max(abs(b) for b in b_bounds)
        self.bmin = min(abs(b) for b in b_bounds)


def _candidate(s: _Setup, d: float, rule: str, tried: list) -> dict | None:
    """One loop at decay ``d``: gains, gamma, a provisional eps and checks (None: rejected).

    The provisional eps is half the smaller of the surrogate's frozen-b eps* (an eigenvalue
    scan, :func:`fl_design.eps_star_curve`) and the real plant's linearized eps*: the LMI
    searches run for the chosen candidate only (:func:`_certified_eps`).
    """
    syn = synthesize_gains(s.rho, decay=d)
    g0 = 5.0 * d * s.T / s.bmin  # |b| gamma / T at least 5 d, for the smallest b too
    eps0, eps_hi = max(2.0 * s.T, 0.2 / d), max(10.0 / d, 20.0 * s.T)
    grid = np.geomspace(s.T / 2.0, eps_hi, 6)
    probe = Design(estimator=EHGO(rho=s.rho, eps=eps0, T=s.T),
                   controller=DynamicController(syn.gains, s.sign * g0, u_limits=s.u_lim))
    while True:  # the probe eps: from 0.2/d down by 4 until some gamma gives a stable loop
        gc = certify_gamma(probe, s.b_bounds, eps_grid=grid, n_scan=40, n_b=21)  # coarse
        if gc.gamma_min is not None:
            break
        if probe.estimator.eps <= 2.0 * s.T:
            tried.append(f"loop at {d:.3g} rad/s: no gamma down to eps = "
                         f"{probe.estimator.eps:.3g}: {gc.reason}")
            return None
        probe = probe.replace(eps=max(2.0 * s.T, probe.estimator.eps / 4.0))
    g_lo, g_hi = 2.0 * gc.gamma_min, gc.gamma_max / 1.25
    if rule == "low" and gc.gamma_lower_bound is not None:
        g_lo = 2.0 * max(gc.gamma_lower_bound, gc.gamma_min)
        g0 = g_lo
    gamma = min(max(g0, g_lo), g_hi) if g_lo <= g_hi else math.sqrt(gc.gamma_min * gc.gamma_max)
    probe = probe.replace(gamma=s.sign * gamma)
    eps_range = (s.T / 2.0, eps_hi)
    frozen = float(eps_star_curve(probe, s.b_bounds, [gamma], eps_range=eps_range,
                                  certified=False).eps_star_frozen[0])
    lin = linearized_eps_star(s.plant, probe, eps_range=eps_range, rtol=1e-3)
    what = f"loop at {d:.3g} rad/s, gamma {s.sign * gamma:.3g}"
    if not np.isfinite(frozen) or (lin.value is None and not lin.above_range):
        tried.append(f"{what}: no stable eps in [{s.T / 2:g}, {eps_hi:g}] s (frozen-b eps* "
                     f"{_g(frozen)}, linearized {lin})")
        return None
    eps_lin = None if lin.above_range else float(lin.lower)
    eps = min(frozen, eps_lin or math.inf) / 2.0
    design = probe.replace(eps=eps)
    check = check_candidate(s.plant, design, s.r)
    if check["status"] not in ("converged", "converging"):
        tried.append(f"{what}, eps {eps:.3g}: the check simulation is {check['status']} "
                     f"({check['response'].verdict()})")
        return None
    gamma_why = ("twice the larger of the certified lower bound over eps and the interval's "
                 "lower end" if rule == "low" else
                 f"5 d T / |b|_min = {s.sign * 5.0 * d * s.T / s.bmin:.3g}, the disturbance "
                 "estimate 5x the loop's rate")
    reasons = [
        (f"gains {tuple(round(k, 6) for k in syn.gains)} (synthesize_gains at decay {d:.3g}: "
        f"{'certified' if syn.certified else 'not certified'})"),
        (f"gamma = {s.sign * gamma:.4g} ({gamma_why}; sign of b; kept inside the admissible "
         f"interval [{gc.gamma_min:.4g}, {gc.gamma_max:.4g}] at eps {probe.estimator.eps:.3g};"
         f" lower bound over eps {_g(gc.gamma_lower_bound)}; paper bound 1/|b|_max = "
         f"{1 / s.bmax:.3g})"),
        f"u_limits = {s.u_lim}"]
    return dict(check, design=design, decay=d, gains=syn, eps_lin=eps_lin, eps_hi=eps_hi,
                frozen=frozen, lin=lin, grid=grid, reasons=reasons)


def _g(x) -> str:
    return "-" if x is None or not np.isfinite(x) else f"{x:.4g}"


def _certified_eps(s: _Setup, c: dict) -> tuple[dict, str, float | None]:
    """The chosen loop's eps: the largest with a certified margin (or the provisional one).

    If the provisional eps is certified, the certified eps* is searched up to the frozen eps*
    and eps becomes the smaller of it and the linearized eps*, over :data:`EPS_MARGIN`, when
    that is larger (and its check converges). Otherwise eps/2, eps/4 are tried; when none is
    certified the provisional eps stays, not certified, and the reason says so.
    """
    design, eps = c["design"], c["design"].estimator.eps
    base = (f"frozen-b eps* {_g(c['frozen'])} (eigenvalue scan), linearized eps* {c['lin']}")
    point = certify_eps(design, s.b_bounds, search=False)
    if not point.certified:
        for f in (0.5, 0.25):
            trial = design.replace(eps=eps * f)
            if certify_eps(trial, s.b_bounds, search=False).certified:
                check = check_candidate(s.plant, trial, s.r)
                if check["status"] in ("converged", "converging"):
                    return (dict(c, **check, design=trial), (f"eps = {eps * f:.4g} s ({base}; "
                            f"half of the smaller not certified, {f / 2:g} of it is)"), None)
        return c, (f"eps = {eps:.4g} s (half the smaller of the {base}); NOT certified there "
                   f"nor at eps/2, eps/4: {point.reason}"), None
    search = certify_eps(design, s.b_bounds, eps_range=(eps, max(c["frozen"], eps * 1.01)),
                         rtol=0.02)
    star = search.eps_star_certified
    new = min(star or eps, c["eps_lin"] or math.inf) / EPS_MARGIN
    if new > eps:
        trial = design.replace(eps=new)
        check = check_candidate(s.plant, trial, s.r)
        if check["status"] in ("converged", "converging"):
            return (dict(c, **check, design=trial), (f"eps = {new:.4g} s (the smaller of the "
                    f"certified eps* {star:.4g} for {search.covers} b and the linearized eps* "
                    f"{c['lin']}, over {EPS_MARGIN:g})"), star)
    return c, (f"eps = {eps:.4g} s (half the smaller of the {base}: certified; the certified "
               f"eps* {_g(star)} over {EPS_MARGIN:g} is not larger)"), star


def _result(s: _Setup, best: dict, label: str, head: list, why: str, tried: tuple,
            baseline) -> Tuning:
    """The chosen candidate with its eps certified, certificates, ranges and the baseline."""
    best, eps_why, star = _certified_eps(s, best)
    design = best["design"]
    ec = certify_eps(design, s.b_bounds, search=False)
    gc = certify_gamma(design, s.b_bounds, eps_grid=best["grid"])
    base = baseline_for(s.plant, baseline, s.r)
    if base is not None:
        base["noise_saved"] = base["noise_gain"] / best["noise_gain"]
    check = best
    reasons = best["reasons"][:2] + [eps_why] + best["reasons"][2:] + [
        (f"checked: a step to {s.r:.6g} is {check['status']} (overshoot "
         f"{check['overshoot']:.3g} %, settling {check['settling_time']:.3g} s); sweep around "
         f"it (eps /2, x1; gamma /2, x1, x2): {check['sweep_ok']}/{len(check['sweep'])} runs "
         "converge"),
        f"noise gain {check['noise_gain']:.4g} (rms u per rms sensor noise)",
        f"certified: eps {ec.certified} ({ec.covers} b), gamma {gc.certified} ({gc.reason})"]
    extra = [] if base is None else [
        (f"vs {base['name']}: noise gain {base['noise_gain']:.3g}, "
         f"{base['noise_saved']:.3g}x ours; its overshoot {base['overshoot']:.3g} % "
         f"({base['status']})")]
    return Tuning(
        design=design, objective=label, reference=s.r, time_scale=best["decay"],
        gains=best["gains"], gamma_certificate=gc, eps_certificate=ec,
        eps_star_certified=star, eps_star_linearized=best["eps_lin"],
        overshoot=best["overshoot"], settling_time=best["settling_time"],
        status=best["status"], noise_gain=best["noise_gain"], sweep_converged=best["sweep"],
        ranges=_ranges(s.T, best["decay"], design.estimator.eps, gc, s.sign), baseline=base,
        reasons=tuple(head + reasons + [f"chosen: {why}"] + extra), tried=tried,
        response=best["response"])


def _ranges(T, d, eps, gc, sign) -> dict:
    """Sweep and certificate ranges: eps from ``T`` to the time scale, gamma from the interval."""
    def rnd(x):
        return float(f"{x:.6g}")

    def signed(a, b):
        return sorted([rnd(sign * a), rnd(sign * b)])
    e_lo, e_hi = rnd(max(T, eps / 10.0)), rnd(max(10.0 / d, 20.0 * eps))
    lower = gc.gamma_min if gc.gamma_lower_bound is None else min(gc.gamma_lower_bound,
                                                                   gc.gamma_min)
    return {"sweep_eps": [e_lo, e_hi], "certify_eps": [e_lo, e_hi],
            "sweep_gamma": signed(lower / 2.0, 2.0 * gc.gamma_max),
            "certify_gamma": signed(gc.gamma_min, gc.gamma_max)}


__all__ = ["Tuning", "nice_time", "tune"]
