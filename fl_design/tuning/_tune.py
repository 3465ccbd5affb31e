"""A design proposed from the plant alone, with its certificates: :func:`tune`.

The paper tunes on hardware ("reduce eps by an order of 10 until stable"); here each number
comes from the plant, the certificates and a check, and is said with its reason:

1. **time scale** ``d``: the largest ``|eigenvalue|`` of the plant linearized at its operating
   point (at least 1 rad/s), at most the rate at which a fifth of the input's room (from
   ``u_eq`` to the nearer limit) moves the step through ``y^(rho) = b u``, i.e.
   ``(0.2 |b|_min room / |step|)^(1/rho)``;
2. **T** (unless given): 100 samples per ``1/d``, rounded down to 1-2-5 (within
   ``[1e-4, 0.1]`` s); at the floor ``1e-4`` s, ``d`` is capped at ``1/(100 T)`` (the loop
   never faster than its sampling allows);
3. **gains**: :func:`fl_design.synthesize_gains` at the loop's decay (all poles at
   ``-(1 + spare) decay``, the decay certified);
4. **gamma** (sign of ``b``), inside the admissible interval of :func:`fl_design.certify_gamma`
   at a probe eps (a factor 2 from its lower end, 1.25 from its upper end where it can; the
   probe eps from ``0.2 / decay`` down by 4 until some gamma is stable): rule ``"fast"``, the
   disturbance estimate ``5x`` the loop's rate for the smallest ``|b|``,
   ``5 decay T / |b|_min``; rule ``"low"``, twice the larger of the certified lower bound
   (below it no eps works) and the interval's lower end (less noise, slower);
5. **eps**: a provisional eps, half the smaller of the surrogate's frozen-b eps* (eigenvalue
   scan, :func:`fl_design.eps_star_curve`) and the real plant's linearized eps*
   (:func:`fl_design.linearized_eps_star`, which sees ``a(x)``), ranks the candidates; the
   chosen one gets the largest of ``min eps* / 1.25`` halved up to 3 times that the LMI
   certifies (one certificate per eps tried, no eps* bisection) and whose check converges and
   meets the objective (:mod:`fl_design.tuning._candidate`, with every fallback);
6. **checked** by a simulation of the step (nonlinear plant, input limits), six runs around
   the design (eps ``/2, x1``, gamma ``/2, x1, x2``), its noise gain
   (:func:`fl_design.analysis.noise_gain`) and its phase margin at the plant input over the
   b-range (:func:`fl_design.analysis.loop_margins`): below :data:`MIN_PHASE_MARGIN` degrees
   the result carries a warning.

Objectives (one default for the API and the CLI, :data:`DEFAULT_OBJECTIVE`):
``"fastest"`` (default: the loop at the plant's time scale ``d`` with the fast gamma; when it
has no design, or no eps with a phase margin of :data:`MIN_PHASE_MARGIN` deg, loops at ``d/2``
and ``d/4``, the documented fallbacks), ``"least-noise"``
(``"least_noise"`` too: loops at ``d``, ``d/2``, ``d/4`` with the low gamma, the least noise
gain wins), ``("overshoot", x)`` (the loop at ``d`` with the fast gamma and the low-gamma loops
at ``d``, ``d/2``, ``d/4``: the least noise gain with an overshoot of at most ``x``, a
fraction). An objective is kept in the final, certified design or the result says by how much
it is missed (``objective_met``, ``warnings``). The default design is required to reach the 2 %
band within :data:`SETTLE_MULTIPLE` times the plant's time constant ``1/d``; slower, the
result carries a warning. A candidate whose gamma interval or eps* is empty, or whose check
does not converge, is said in ``tried``; when none is left
:class:`~fl_design.errors.NoDesignError` says why, per candidate and step.

Examples
--------
>>> import fl_design as fl
>>> tuned = fl.tune(fl.plants.pendulum(), reference=0.1)
>>> tuned.certified, tuned.status, tuned.design.estimator.T
(True, 'converged', 0.002)
"""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as V
from .._progress import Lines
from ..analysis import certify_gamma
from ..design import Design
from ..errors import FlDesignError, NoDesignError, ParameterError, RelativeDegreeError
from ..symbolic import Plant
from ._candidate import CONVERGENT, MIN_PHASE_MARGIN, Setup, candidate, certified_eps, g_text
from ._check import baseline_for, step_target
from ._tune_class import PlantClass, tune_class
from ._tuning import Tuning

#: Candidates per objective: (loop decay over the plant's time scale, gamma rule); "fast":
#: the disturbance estimate 5x the loop's rate, "low": near the certified lower bound.
CANDIDATES = {"least-noise": ((1.0, "low"), (0.5, "low"), (0.25, "low")),
              "fastest": ((1.0, "fast"),),
              "overshoot": ((1.0, "fast"), (1.0, "low"), (0.5, "low"), (0.25, "low"))}
#: Fallback loops (factors of the time scale) when every candidate of the objective fails
#: (and, for the default objective, when the loop has no eps with a 30 deg phase margin).
FALLBACKS = (0.5, 0.25)
#: The shortest sampling time proposed (s); a faster plant's loop is slowed to 1/(100 T_MIN).
T_MIN = 1e-4
#: The objective of ``fl.tune`` and of ``fl-design run`` without ``[design]``.
DEFAULT_OBJECTIVE = "fastest"
#: The default design reaches the 2 % band within this many plant time constants ``1/d``.
SETTLE_MULTIPLE = 50.0


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
        return step_target(y_op, plant.region[out])
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


def tune(plant: Plant, *, T: float | None = None, objective=None,
         reference: float | None = None, u_limits=None, decays=None,
         baseline="auto", progress="auto") -> Tuning:
    """Propose a certified, checked design for ``plant`` (the module says how and why).

    Parameters
    ----------
    plant : Plant
        A plant with a ``region`` and an ``input_range`` (they give the b-range), inside the
        method's assumptions (minimum phase, sign of ``b`` known on the region).
    T : float, optional
        Sampling time (default from the plant's time scale and the actuator, step 2).
    objective : str or tuple, optional
        ``"fastest"`` (default for a plant, :data:`DEFAULT_OBJECTIVE`), ``"least-noise"``
        (``"least_noise"`` too) or ``("overshoot", x)``, ``x`` a fraction. For a
        :class:`~fl_design.PlantClass` the default is ``"least-noise"`` (API and
        ``fl-design run CLASS.toml`` alike): a design for a whole class knows neither the
        plant's time scale nor its noise path, and the fastest certified loop amplifies sensor
        noise by thousands at the wide end of ``b``.
    reference : float, optional
        The step target of the checks (default the operating output plus 5 % of the output's
        range in the region).
    u_limits : (float, float), optional
        Input saturation (default the plant's ``input_range``); must contain ``u_eq``.
    decays : sequence of float, optional
        The loop decays to try, as factors of the plant's time scale (default per objective,
        see the module); each costs certificates and checks.
    baseline : Design, None or "auto", optional
        A design to compare noise and overshoot with; ``"auto"`` (default): the paper's design
        for the library TRMS (:func:`fl_design.presets.paper_design`), else none.
    progress : bool or "auto", optional
        One line per step on stderr (the loop tried, each eps certificate, the final
        certificates; for a class each candidate's scan, certificate and member runs) with
        the seconds so far: ``True`` from the start, ``False`` never, ``"auto"`` (default)
        once the call has run 2 s (:mod:`fl_design._progress`).

    Returns
    -------
    Tuning

    Raises
    ------
    ParameterError
        A bad ``T``, ``objective``, ``reference``, ``u_limits`` or ``baseline``.
    AssumptionError
        The plant is not minimum phase, or ``b`` vanishes or changes sign on the region
        (:func:`fl_design.symbolic.check_assumptions`: eigenvalues or the point).
    NoDesignError
        No region or input range, ``u_eq`` outside the limits, or no candidate with a
        nonempty gamma interval, an eps and a converging check (the message says, per
        candidate, which step failed and why), also after the fallback loops.

    Examples
    --------
    >>> import fl_design as fl
    >>> tuned = fl.tune(fl.plants.pendulum(), reference=0.1)
    >>> tuned.certified, tuned.status, [round(k, 4) for k in tuned.design.controller.gains]
    (True, 'converged', [10.2063, 6.3895])
    """
    if isinstance(plant, PlantClass):  # what a rig owner knows: designed for every member
        return tune_class(plant, T=T, objective="least-noise" if objective is None else objective,
                          reference=reference, u_limits=u_limits,
                          progress=Lines("fl.tune", progress))
    if objective is None:
        objective = DEFAULT_OBJECTIVE
    V.instance("plant", plant, Plant, "an fl.Plant (fl.Plant.from_ode or fl.plants.*)")
    kind, limit = _objective(objective)
    if not (baseline is None or isinstance(baseline, Design) or
            (isinstance(baseline, str) and baseline == "auto")):
        raise ParameterError(f"baseline={baseline!r}: give a Design, None or 'auto'")
    from ..symbolic._assumptions import check_assumptions

    rho = plant.relative_degree()
    check_assumptions(plant, what="fl.tune")
    lo, hi = _b_range(plant)
    u_lim = tuple(plant.input_range) if u_limits is None else V.interval("u_limits", u_limits)
    if not u_lim[0] < plant.u_eq < u_lim[1]:
        raise NoDesignError(f"no design for {plant.name!r}: the equilibrium input u_eq = "
                            f"{plant.u_eq:.6g} is not inside u_limits {u_lim}: no room to act")
    y_op = float(plant.casadi().h(plant.x_op))
    r = _reference(plant, reference, y_op)
    decay, head, full_reach = _time_scale(plant, rho, (lo, hi), u_lim, r, y_op)
    if T is None:
        T, T_why = (min(0.1, max(T_MIN, nice_time(1.0 / (100.0 * decay)))),
                    "100 samples per 1/time scale, 1-2-5 rounded")
        if decay * T > 0.01 * (1 + 1e-9):  # T at its floor: the loop slowed to fit it
            head.append(f"loop time scale capped at {0.01 / T:.3g} rad/s, 100 samples per time "
                        f"constant at T = {T:g} s (the shortest T proposed; give T to go faster)")
            decay = 0.01 / T
    else:
        T, T_why = V.positive("T", T), "given"
    head.append(f"T = {T:g} s ({T_why})")
    accept = _acceptance(kind, limit)
    loop = Setup(plant, rho, T, (lo, hi), u_lim, r, accept, progress)
    loop.say(head[0].split(' (')[0] + f', T = {T:g} s, step to {r:.6g}')
    cands = list(CANDIDATES[kind])
    if decays is not None:
        factors = [V.positive("decays entry", f) for f in V.real_vector("decays", decays)]
        if not factors:
            raise ParameterError("decays is empty: give factors of the time scale, e.g. (1.0,)")
        rules = {rule for _, rule in cands}
        cands = [(f, rule) for f in factors for rule in sorted(rules)]
    tried: list = []
    chosen = _run(loop, cands, decay, full_reach, accept, tried)
    if not chosen and decays is None:  # the documented fallback: slower loops
        rule = cands[0][1]
        chosen = _run(loop, [(f, rule) for f in FALLBACKS if (f, rule) not in cands], decay,
                      full_reach, accept, tried)
    if not chosen:
        raise NoDesignError(f"no design for {plant.name!r} ({kind}): " + "; ".join(tried))
    key = ((lambda c: c["settling_time"]) if kind == "fastest" else (lambda c: c["noise_gain"]
                                                                     if np.isfinite(c["noise_gain"]) else math.inf))
    best = min(chosen, key=key)
    final = certified_eps(loop, best)
    if kind == "fastest" and decays is None and not final[3] >= MIN_PHASE_MARGIN:
        for f in FALLBACKS:  # the default design needs its margin: slower loops
            alt = _run(loop, [(f, "fast")], decay, full_reach, accept, tried,
                       margin_needed=True)
            fin = certified_eps(loop, alt[0]) if alt else None
            if fin is not None and fin[3] >= MIN_PHASE_MARGIN:
                tried.append(f"loop at {best['decay']:.3g} rad/s: phase margin "
                             f"{final[3]:.3g} deg < {MIN_PHASE_MARGIN:g} deg at every eps "
                             f"tried; the loop at {alt[0]['decay']:.3g} rad/s has "
                             f"{fin[3]:.3g} deg")
                best, final, chosen = alt[0], fin, alt
                break
    label = kind if kind != "overshoot" else f"overshoot <= {100 * limit:g} %"
    why = {"least-noise": f"the least noise gain of {len(chosen)} converging loops",
           "fastest": f"the shortest settling time of {len(chosen)} converging loops",
           "overshoot": (f"the least noise gain of {len(chosen)} converging loops with overshoot "
                         f"<= {100 * (limit or 0):g} %")}[kind]
    others = [f"also: loop at {c['decay']:.3g} rad/s, gamma {c['design'].controller.gamma:.3g}, "
              f"eps {c['design'].estimator.eps:.3g}: noise gain {c['noise_gain']:.3g}, "
              f"settling {c['settling_time']:.3g} s, overshoot {c['overshoot']:.3g} %"
              for c in chosen if c is not best]
    return _result(loop, final, label, head + [f"chosen: {why}"], tuple(tried + others),
                   baseline, decay)


def _time_scale(plant, rho, b, u_lim, r, y_op) -> tuple[float, list, float]:
    """``(d, [sentence], full reach)``: the plant's time scale (step 1 of the module)."""
    A = np.asarray(plant.linearization()[0], dtype=float)
    speed = float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0
    step, room = abs(r - y_op), min(plant.u_eq - u_lim[0], u_lim[1] - plant.u_eq)
    bmin = min(abs(b[0]), abs(b[1]))
    reach = (0.2 * bmin * room / step) ** (1.0 / rho) if step > 0 else math.inf
    decay = max(0.01, min(max(1.0, speed), reach))
    head = [(f"time scale {decay:.3g} rad/s (largest |eigenvalue| of the linearization "
             f"{speed:.3g}, at least 1; at most {reach:.3g}, what a fifth of the input's room "
             f"{room:.3g} moves the step {step:.3g} at)")]
    return decay, head, reach * 5.0 ** (1.0 / rho)


def _acceptance(kind: str, limit):
    """``accept(check) -> str | None``: how a check misses the objective (None: it meets it)."""
    if kind != "overshoot":
        return None
    return lambda c: (None if c["overshoot"] <= 100.0 * limit else
                      f"overshoot {c['overshoot']:.3g} % > {100 * limit:g} %")


def _run(loop: Setup, cands, decay: float, full_reach: float, accept, tried: list,
         margin_needed: bool = False) -> list:
    """The candidates that pass (each failure said in ``tried``; ``margin_needed``: see
    :func:`~fl_design.tuning._candidate.candidate`)."""
    chosen = []
    for f, rule in cands:
        d = decay * f
        if d > full_reach * (1 + 1e-12) or d < 0.01:
            tried.append(f"loop at {d:.3g} rad/s: outside [0.01, {full_reach:.3g}] (the whole "
                         "input room)")
            continue
        try:
            cand = candidate(loop, d, rule, tried, margin_needed)
        except FlDesignError as exc:  # a step without its own fallback: said, not raised
            tried.append(f"loop at {d:.3g} rad/s ({rule} gamma): {type(exc).__name__}: "
                         f"{str(exc).splitlines()[0][:200]}")
            continue
        if cand is None:
            continue
        miss = accept(cand) if accept else None
        if miss:
            tried.append(f"loop at {d:.3g} rad/s, gamma {cand['design'].controller.gamma:.3g}: "
                         f"{miss}")
            continue
        chosen.append(cand)
    return chosen


def _result(s: Setup, final: tuple, label: str, head: list, tried: tuple, baseline,
            plant_scale: float) -> Tuning:
    """The chosen candidate with its eps certified (:func:`certified_eps`'s answer),
    certificates, margins, ranges, baseline."""
    best, eps_why, ec, pm = final
    if ec is None:
        raise NoDesignError(f"no design for {s.plant.name!r}: the eps certificate (LMI) failed "
                            f"at every eps tried: {eps_why}")
    design = best["design"]
    s.say("the gamma certificate at the design, the baseline")
    try:
        gc = certify_gamma(design, s.b_bounds, eps_grid=best["grid"])
    except FlDesignError as exc:
        raise NoDesignError(f"no design for {s.plant.name!r}: the gamma certificate failed at "
                            f"the chosen design: {exc}") from exc
    try:
        base = baseline_for(s.plant, baseline, s.r)
    except FlDesignError as exc:  # the comparison is extra: said, never a crash
        base, head = None, head + [f"baseline not compared: {str(exc)[:160]}"]
    if base is not None:
        base["noise_saved"] = base["noise_gain"] / best["noise_gain"]
    warnings = []
    miss = s.accept(best) if best["status"] in CONVERGENT else f"the check is {best['status']}"
    if miss:
        warnings.append(f"objective {label} missed: {miss}")
    if pm < MIN_PHASE_MARGIN:
        warnings.append(f"phase margin {pm:.3g} deg < {MIN_PHASE_MARGIN:g} deg at the plant "
                        "input (worst over the b-range): little robustness to delay and "
                        "unmodeled lag")
    settle = best["settling_time"]
    bound = SETTLE_MULTIPLE / plant_scale
    if not settle <= bound:
        warnings.append(f"settling {g_text(settle)} s > {SETTLE_MULTIPLE:g} plant time "
                        f"constants ({bound:.3g} s)")
    check = best
    reasons = best["reasons"][:2] + [eps_why] + best["reasons"][2:] + [
        (f"checked: a step to {s.r:.6g} is {check['status']} (overshoot "
         f"{check['overshoot']:.3g} %, settling {check['settling_time']:.3g} s = "
         f"{check['settling_time'] * plant_scale:.3g} plant time constants, at most "
         f"{SETTLE_MULTIPLE:g}); runs around it (eps /2, x1; gamma /2, x1, x2): "
         f"{check['sweep_ok']}/{len(check['sweep'])} converge"),
        f"noise gain {check['noise_gain']:.4g} (rms u per rms sensor noise)" +
        (f"; {check['noise_note']}" if check.get("noise_note") else ""),
        f"phase margin {pm:.3g} deg at the plant input (worst of b_min, b_max)",
        (f"certified: eps {ec.certified} ({ec.covers} b), gamma {gc.certified} ({gc.reason}); "
         f"for the surrogate class b in [{s.b_bounds[0]:.6g}, {s.b_bounds[1]:.6g}], a = 0 "
         "(the chain), not this plant's class (the slopes of its a(x)): "
         "fl.certify_eps(design, fl.PlantClass.from_plant(plant)) answers for that")]
    extra = [] if base is None else [
        (f"vs {base['name']}: noise gain {base['noise_gain']:.3g}, "
         f"{base['noise_saved']:.3g}x ours; its overshoot {base['overshoot']:.3g} % "
         f"({base['status']})")]
    return Tuning(
        design=design, objective=label, reference=s.r, time_scale=best["decay"],
        gains=best["gains"], gamma_certificate=gc, eps_certificate=ec,
        eps_star_certified=None, eps_star_linearized=best["eps_lin"],
        overshoot=best["overshoot"], settling_time=best["settling_time"],
        status=best["status"], noise_gain=best["noise_gain"], sweep_converged=best["sweep"],
        ranges=_ranges(s.T, best["decay"], design.estimator.eps, gc, s.sign), baseline=base,
        reasons=tuple([h for h in head if not h.startswith('chosen:')] + reasons +
                      [h for h in head if h.startswith('chosen:')] + extra), tried=tried,
        response=best["response"], objective_met=not miss, phase_margin=pm,
        plant_time_scale=plant_scale, warnings=tuple(warnings))


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


__all__ = ["DEFAULT_OBJECTIVE", "MIN_PHASE_MARGIN", "SETTLE_MULTIPLE", "Tuning", "nice_time", "tune"]
