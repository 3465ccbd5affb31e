"""Is this step, from this start, certified? :func:`certify_step` answers for a plant or a class.

**Argument (why this one).** An invariant ellipsoid of the sampled loop, with the input limits
and the estimate clamps inside it as sector-bounded dead-zones (generalized sector condition)
and bounded sensor noise as an input (:mod:`._sector`): ``V = X^T P X``, ``P`` the common
quadratic of the nonlinear (LDI) certificate (:func:`._ldi.ldi_point`: ``d sigma/d xi`` in a box,
``b`` in its range, both varying in time), the level and the multipliers from small SDPs,
everything re-checked in NumPy with a margin. The start (plant at rest at ``x0``, the observer at
rest at the first measurement, ``u`` at its start value, ``z = 0``) is certified when its
deviation from the target equilibrium lies in the ellipsoid: the trajectory then stays in it
(the slope box and ``b``'s range hold there) and converges (``V`` contracts every sample), or,
with noise bounded by ``nbar``, enters ``V <= mu nbar^2 / kappa``. It is chosen because it
covers a *class* (every plant whose slopes stay in the box) and puts saturation, clamps and
noise inside one argument; a validated simulation would certify one model only, and needs
rigorous enclosures over ~10^5-10^6 samples for the TRMS (its slow mode near rest is ~200 s).

**What it cannot do (said in the result).** A common quadratic cannot cover a slope box as wide
as the TRMS friction's ([-505, -5] 1/s over ``|phi'| <= 3``): the region is shrunk about the
target (scales tried in turn) until the LDI certifies, so the TRMS's certified steps are tiny.
With ``friction=(a0, k)`` (the caller states ``sigma = -a0 x_2 - phi(x_2) + g(u)``, ``phi``
monotone with slope in ``[0, k]``) the global Lur'e certificate of :mod:`._lure` (Popov/Jury-Lee
type ``V``) is tried first; measured, it covers ``k <= 13.1`` with ``b in [3.6, 6.8]`` and no
limits (22.1 with ``b`` frozen), not the TRMS's ``k = 500``, and nothing with the paper's limits
as global sectors. Zames-Falb multipliers and validated reachability are not implemented. With a plant, the region's room is kept between samples: ``x_i`` (``i < rho``)
moves by at most ``T`` times the room of ``x_(i+1)``; ``x_rho`` needs no margin when ``sigma``
depends on the states only through ``x_rho`` (checked symbolically: a scalar autonomous ODE
over the sample, so ``x_rho(t)`` is monotone between two samples, both in the ellipsoid), else
``T sup|sigma - sigma_eq|`` (mean-value bound). A class's slopes hold by assumption everywhere.

**Measured** (``verify/claim_12_step_certified.py``; times from ``verify/bench_step_cert.py``,
CPU in one process, 2 shared cores at load ~2.6):
the pendulum's 0.1 rad step is certified (largest certified step 0.28 rad, 0.2 s, 4 conic
programs; the plant's region |theta - r| <= 3.04, the slopes by interval arithmetic); the
paper's design on the class ``y'' = b u``, ``b in [3.6, 6.8]``, ``|u| <= 2.5``,
``|xhat_2| <= 0.05`` is NOT certified for 0.3 rad (``V(start)/level = 27``; largest certified
step 0.058 rad, which converges in ``fl.simulate`` for b = 3.6 and 6.8; 0.3 rad diverges on
``y'' = 5 u``); the TRMS's 0.3 rad step is NOT certified: the largest certified step is
4.3e-5 rad (region ``|phi'| <= 3e-4``, ``|u| <= 2.5e-3``, slopes [-505, -462.6]; 1.2 s, 8
conic programs), every larger region tried has no common quadratic (at ``|phi'| <= 6e-4``,
slopes [-505, -350], already none). The largest certified step depends on the start-covering
``P`` (:mod:`._start_lmi`), whose LMI has no unique minimizer: equivalent programs (CVXPY's
canonical form, the direct one) stop at different minimizers, and the TRMS's step moved
4.4e-5 -> 4.3e-5 when the program went to Clarabel directly (the pendulum's 0.2823 ->
0.2817, the chain class's 0.05775 -> 0.05781); verdicts and regions did not move.

**Cost.** The work is conic programs (an LDI LMI, the start-covering LMI and one or two
levels of the sector ellipsoid per certified region, Clarabel called directly, one thread)
and thousands of tiny dense problems (run with one OpenBLAS thread: the pool's wake-ups
doubled the CPU time). The LDI certificate's ``P`` is passed over when no level it could
reach (:func:`._sector.level_cap`) beats the start-covering ``P``'s ``V(start)/level``.

Examples
--------
>>> import fl_design as fl
>>> cls = fl.PlantClass.chain(2, b=(3.6, 6.8), T=1e-3)
>>> c = certify_step(cls, fl.presets.paper_design(), fl.Scenario(0.3))
>>> c.certified, c.largest_step < 0.3
(False, True)
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ._cert_results import _Result

#: Pairs of LDI vertex loops whose switching is tried before the LMIs of a region (a growing
#: one shows no common P exists: the region is passed over without an LMI).
REFUTE_PAIRS = 8
#: Scales of the plant's region (about the target) tried in turn.
REGION_SCALES = ((1.0, 1.0), (0.1, 0.1), (1e-2, 1e-2), (1e-3, 1e-3), (1e-4, 1e-3),
                 (3e-5, 1e-3))


@dataclass(frozen=True, repr=False)
class StepCertificate(_Result):
    """The answer of :func:`certify_step`.

    Parameters
    ----------
    certified : bool
        The step from the start is certified bounded and converging (to the ultimate set with
        noise).
    step : float
        The step asked (target minus start output).
    largest_step : float
        The largest step (same target, start at rest) the best ellipsoid certifies.
    argument : str
        Which argument, on which class, with which numbers.
    covered : str
        What the certificate covers.
    uncovered : str
        What it does not cover.
    start_ratio : float
        ``V(X0) / level`` (<= 1: covered).
    region_scale : (float, float)
        Scales of the plant's state region and input range about the target used ((1, 1) for
        a class).
    seconds : float
        Wall time.
    P : numpy.ndarray or None
        ``V``'s matrix over the loop coordinates ``names`` (None: no certificate).
    level : float
        The certified sublevel of ``V`` (the covered loop states ``V(X) <= level``).
    names : tuple of str
        The loop coordinates of ``P`` (deviations from the target equilibrium).
    """

    certified: bool
    step: float
    largest_step: float
    argument: str
    covered: str
    uncovered: str
    start_ratio: float
    region_scale: tuple
    seconds: float
    P: object = None
    level: float = math.nan
    names: tuple = ()

    def _repr_lines(self):
        head = "certified" if self.certified else "NOT certified"
        return [f"{head}: step {self.step:g} (largest certified {self.largest_step:.4g})",
                self.argument, "covers: " + self.covered, "not covered: " + self.uncovered,
                f"({self.seconds:.2f} s)"]


def _start(design, y0, r, u0, u_eq, estimate=None):
    """Loop deviation of the start from the target equilibrium (all states, before ``keep``)."""
    rho = design.rho
    s0 = design.initial_state(y0=y0, estimate=estimate, u0=u0)
    se = design.initial_state(y0=r, u0=u_eq)
    x = np.zeros(rho)
    x[0] = y0 - r
    return np.concatenate([x, s0 - se])


def _largest(E, Xc, d, step):
    """Largest ``s`` with ``V(Xc + s d) <= level`` for all ``s`` in ``[0, s]`` (``Xc`` inside)."""
    a, b, c = float(d @ E.P @ d), 2.0 * float(Xc @ E.P @ d), float(Xc @ E.P @ Xc) - E.level
    if c > 0 or a <= 0:
        return 0.0
    return abs(step) * (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)


def _sigma_uses_top_only(plant) -> bool:
    chain = plant._lie_chain()
    used = chain.derivatives[chain.rho].free_symbols
    return not any(s in used for s in plant.states[: chain.rho - 1])


def certify_step(plant_or_class, design, scenario, *, noise_bound: float | None = None,
                 region_scales=REGION_SCALES, friction=None, time_budget: float | None = None,
                 progress=None) -> StepCertificate:
    """Is the scenario's step certified (bounded and converging)? By which argument?

    Parameters
    ----------
    plant_or_class : Plant or PlantClass
        A plant (``rho = n``; its slopes and ``b`` enclosed over a region about the target by
        interval arithmetic) or a class (its slope box and ``b`` range, assumed everywhere).
    design : Design
        An EHGO design (``b > 0``); its input limits and estimate clamps are inside the
        certificate.
    scenario : Scenario
        A constant reference; the start ``x0`` (default the plant's operating point, 0 for a
        class); the noise must be bounded (``noise_bound``) to be covered.
    noise_bound : float, optional
        Peak of the sensor noise covered (quantization adds half its step).
    region_scales : sequence of (float, float), optional
        Scales in (0, 1] of the plant's state region and input range about the target, tried
        in turn until the start is covered (default :data:`REGION_SCALES`).
    friction : (float, float), optional
        ``(a0, k)``: the caller states the structure ``sigma = -a0 x_2 - phi(x_2) + g(u)``
        with ``phi`` static, monotone, ``phi(0) = 0``, slope in ``[0, k]``, and ``g(u)/u`` in
        ``b``'s range (``rho = 2``, ``u_eq = 0``). The global Lur'e certificate of
        :mod:`._lure` is tried first; if it holds, every start is certified for that class,
        else its reason is listed as not covered and the ellipsoid argument follows.
    time_budget : float, optional
        Seconds after which no further (smaller) region is tried; the regions not tried are
        named in ``uncovered``. Default: no budget.
    progress : callable, optional
        ``progress(done, total)`` before each region (a caller's progress line).

    Returns
    -------
    StepCertificate

    Raises
    ------
    ParameterError
        A non-constant reference, a design/class mismatch, a negative noise bound, bad region
        scales, a plant with internal dynamics or whose normal-form coordinates are not its
        states (the reason says what would be needed).

    Examples
    --------
    >>> import fl_design as fl
    >>> c = certify_step(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1))
    >>> c.certified
    True
    """
    from .._blas import serial_blas

    with serial_blas():  # thousands of tiny dense problems: one OpenBLAS thread (2x less CPU)
        return _certify_step(plant_or_class, design, scenario, noise_bound, region_scales,
                             friction, time_budget, progress)


def _certify_step(plant_or_class, design, scenario, noise_bound, region_scales, friction,
                  time_budget, progress):
    from ..symbolic import Plant
    from ._plant_class import PlantClass

    t0 = time.perf_counter()
    ref = scenario.reference
    if callable(ref) or np.ndim(ref) != 0:
        raise ParameterError(f"certify_step needs a constant reference (a step), got {ref!r}")
    r = float(ref)
    nbar = 0.0 if noise_bound is None else float(noise_bound)
    if not (math.isfinite(nbar) and nbar >= 0):
        raise ParameterError(f"noise_bound must be a finite number >= 0, got {noise_bound!r}")
    try:
        region_scales = tuple((float(a), float(b_)) for a, b_ in region_scales)
    except (TypeError, ValueError):
        raise ParameterError(f"region_scales must be pairs (state scale, input scale), got "
                             f"{region_scales!r}") from None
    if not region_scales or not all(0 < a <= 1 and 0 < b_ <= 1 for a, b_ in region_scales):
        raise ParameterError(f"region_scales must be non-empty pairs in (0, 1], got "
                             f"{region_scales!r}")
    if scenario.quantization:
        nbar += 0.5 * float(scenario.quantization)
    uncovered = []
    cls_bound = getattr(plant_or_class, "noise_bound", None)
    if scenario.noise.std > 0 and noise_bound is None and cls_bound is None:
        uncovered.append(f"the scenario's Gaussian noise (std {scenario.noise.std:g}) is "
                         "unbounded: give noise_bound to cover a bounded noise")
    if scenario.disturbance is not None:
        uncovered.append("the scenario's disturbances")
    if isinstance(plant_or_class, PlantClass):
        cls = plant_or_class
        if cls.rho != design.rho:
            raise ParameterError(f"the class has rho = {cls.rho}, the design rho = {design.rho}")
        if cls.delay or cls.zero_dynamics != "none":
            why = (f"an input delay of {cls.delay} samples" if cls.delay else
                   f"internal dynamics ({cls.zero_dynamics})")
            return StepCertificate(False, r - (0.0 if scenario.x0 is None else float(
                np.ravel(scenario.x0)[0])), 0.0, f"no certificate: the class has {why}, which "
                "the step certificate does not model (rho = n, no delay)", "nothing",
                f"{why}", math.inf, (1.0, 1.0), time.perf_counter() - t0)
        u_eq = float(cls.u_eq) if cls.u_eq is not None else 0.0
        if cls.a_slopes is not None and cls.u_eq is None:
            uncovered.append("u_eq of the class is unknown: taken as 0")
        if noise_bound is None and cls.noise_bound is not None:
            nbar += float(cls.noise_bound)  # the class's own peak bound of the noise
        lim = design.controller.u_range
        if cls.u_limits is not None and (lim is None or lim[0] < cls.u_limits[0]
                                         or lim[1] > cls.u_limits[1]):
            uncovered.append(f"the actuator's own limits {tuple(cls.u_limits)} (the design "
                             f"does not saturate inside them: {lim})")
        y0 = 0.0 if scenario.x0 is None else float(np.ravel(scenario.x0)[0])
        X0 = _start(design, y0, r, u_eq, u_eq, scenario.initial_estimate)
        tries = [((1.0, 1.0), cls.b, cls.a_slopes, u_eq, {}, cls.describe())]
        uncovered.append("plants outside the class (its slope box and b range are assumed to "
                         "hold along every trajectory)")
    elif isinstance(plant_or_class, Plant):
        plant = plant_or_class
        from ._region import _check_chain

        _check_chain(plant)  # a refused plant says why before any equilibrium is solved
        eq = plant.equilibrium(y=r)
        x_eq, u_eq = np.asarray(eq.x, float), float(eq.u)
        x0 = (np.asarray(plant.x_op, float) if scenario.x0 is None
              else np.asarray(scenario.x0, float).ravel())
        u0 = float(plant.u_eq) if design.controller.u0 is None else design.controller.u0
        if design.controller.u_range is not None:
            u0 = float(np.clip(u0, *design.controller.u_range))
        X0 = _start(design, float(x0[0]), r, u0, u_eq, scenario.initial_estimate)
        X0[: design.rho] = x0[: design.rho] - x_eq[: design.rho]
        tries = _plant_tries(plant, design, x_eq, u_eq, region_scales)
    else:
        raise ParameterError(f"plant_or_class must be a fl.Plant or a fl.PlantClass, got "
                             f"{type(plant_or_class).__name__}")
    lure_out = _try_lure(plant_or_class, design, friction)
    if lure_out is not None and lure_out.certified and nbar == 0 and scenario.disturbance is None \
            and not scenario.noise.std > 0:
        step0 = r - float(X0[0] + r)
        return StepCertificate(True, step0, math.inf, lure_out.argument,
                               "every start, every plant of the stated Lur'e class (no noise)",
                               "; ".join(uncovered + ["plants outside the stated structure"]),
                               0.0, (1.0, 1.0), time.perf_counter() - t0, lure_out.P, math.inf,
                               lure_out.names)
    if lure_out is not None:
        uncovered.append(f"the Lur'e argument ({lure_out.argument})" if not lure_out.certified
                         else "the Lur'e certificate (it holds without noise or disturbances "
                         "only)")
    uncovered.append("starts outside the ellipsoid (the saturated loop's larger region of "
                     "attraction is not claimed); b's rate limits are not used (b varies "
                     "arbitrarily in its range: conservative)")
    step = r - float(X0[0] + r)
    best, fails = None, []
    if time_budget is not None and not (math.isfinite(float(time_budget))
                                        and float(time_budget) >= 0):
        raise ParameterError(f"time_budget must be a finite number >= 0 seconds, got "
                             f"{time_budget!r}")
    n_tries = 1 if isinstance(plant_or_class, PlantClass) else len(region_scales)
    for k, (scale, b, box, ueq, rooms_fn, words) in enumerate(tries):
        if time_budget is not None and k and time.perf_counter() - t0 > time_budget:
            uncovered.append(f"regions at scales {', '.join(str(x) for x in region_scales[k:])}"
                             f": not tried, the time budget of {time_budget:g} s was spent")
            break
        if progress is not None:
            progress(k, n_tries)
        out = _one(design, b, box, ueq, rooms_fn, X0, nbar, words, scale)
        if isinstance(out, str):
            fails.append(out)
            if best is None or best[0] is None:
                best = (None, out, scale)
            continue
        if best is not None and best[0] is not None and out[1] <= best[0][1]:
            break  # a smaller region certifies a smaller step: stop
        best = (out, "", scale)
        if out[4] <= 1.0:
            break
    res, why, scale = best if best is not None else (None, "no region tried", (1.0, 1.0))
    secs = time.perf_counter() - t0
    if res is None:
        return StepCertificate(False, step, 0.0, f"no certificate: {why}", "nothing",
                               "; ".join(uncovered), math.inf, scale, secs)
    E, largest, argument, covered, ratio = res
    if fails and ratio > 1.0:
        uncovered.insert(0, f"the larger regions ({len(fails)} tried; the smallest of them "
                            f"{fails[-1]})")
    ok = ratio <= 1.0 and not (scenario.noise.std > 0 and noise_bound is None
                               and cls_bound is None) and scenario.disturbance is None
    from ._surrogate import SurrogateLoop

    loop = SurrogateLoop(design)
    return StepCertificate(bool(ok), step, largest, argument, covered, "; ".join(uncovered),
                           ratio, scale, secs, E.P, float(E.level),
                           tuple(loop.names[i] for i in loop.keep))


def _try_lure(plant_or_class, design, friction):
    """The global Lur'e certificate for the stated friction structure, or None (not asked)."""
    if friction is None:
        return None
    from ._lure import lure_certificate

    try:
        a0, k = (float(x) for x in friction)
    except (TypeError, ValueError):
        raise ParameterError(f"friction must be (a0, k), two numbers, got {friction!r}") from None
    b = getattr(plant_or_class, "b", None)
    if b is None or callable(b):
        b = plant_or_class.b_bounds()
    return lure_certificate(design, tuple(float(x) for x in b), a0, k)


def _plant_tries(plant, design, x_eq, u_eq, scales):
    """``(scale, b, box, u_eq, rooms, words)`` of the plant's region scaled about the target."""
    from ._plant_bounds import plant_bounds
    from ._region import _check_chain

    _check_chain(plant)
    chain = plant._lie_chain()
    used = chain.derivatives[chain.rho].free_symbols
    top_only = _sigma_uses_top_only(plant)
    rho, T = design.rho, design.T
    for s, s_u in scales:
        region, half = {}, []
        for st, xe in zip(plant.states, x_eq):
            lo, hi = plant.region[st]
            w = s * min(xe - lo, hi - xe) if st in used else None
            region[str(st)] = (xe - w, xe + w) if w is not None else (lo, hi)
            half.append(w)
        ur = plant.input_range
        if ur is not None:
            ur = (u_eq - s_u * (u_eq - ur[0]), u_eq + s_u * (ur[1] - u_eq))
        pb = plant_bounds(plant, region=region, T=T, input_range=ur)
        if pb.a_jacobian_bounds is None:
            continue
        box = pb.a_jacobian_bounds
        rooms = {}
        sig = sum(max(abs(a), abs(b_)) * (w or 0.0) for (a, b_), w in zip(box, half))
        if ur is not None:
            sig += pb.b_bounds[1] * max(abs(ur[0] - u_eq), abs(ur[1] - u_eq))
        for i, w in enumerate(half):
            if w is None:
                continue
            if i < rho - 1:
                nxt = half[i + 1] if half[i + 1] is not None else plant.region[plant.states[i + 1]][1]
                rooms[i] = w - T * abs(nxt)
            else:
                rooms[i] = w if top_only else w - T * sig
        lim = design.controller.u_range
        if ur is not None and (lim is None or lim[0] < ur[0] or lim[1] > ur[1]):
            # b's bounds hold on the input range: keep u inside it (saturation does not)
            rooms[rho + design.state_layout["u"].start] = min(u_eq - ur[0], ur[1] - u_eq)
        words = (f"the plant {plant.name!r} in the region "
                 + ", ".join(f"{n} in [{lo:.4g}, {hi:.4g}]" for n, lo, hi in pb.region)
                 + (f", u in [{ur[0]:.4g}, {ur[1]:.4g}]" if ur is not None else "")
                 + f" (scale {s:g}, input scale {s_u:g} about the target), b in [{pb.b_bounds[0]:.4g}, "
                 f"{pb.b_bounds[1]:.4g}], d sigma/d xi in "
                 + ", ".join(f"[{a:.4g}, {b_:.4g}]" for a, b_ in box)
                 + " (interval enclosures)")
        yield (s, s_u), pb.b_bounds, box, u_eq, rooms, words


def _one(design, b, box, u_eq, rooms, X0, nbar, words, scale):
    """One region: LDI ``P``, then the sector ellipsoid; a tuple or the reason (str)."""
    from ._certify import _Loop
    from ._ldi import ldi_point
    from ._sector import level_cap, loop_channels, solve_ellipsoid
    from ._start_lmi import widest_start_p

    if any(r <= 0 for r in rooms.values()):
        return f"at scales {scale} the region leaves no room after the inter-sample margin"
    eps, gamma = float(design.estimator.eps), float(design.controller.gamma)
    L = _Loop(design, b, box, 41, 8)
    pc = ldi_point(L, eps, gamma, refute_pairs=REFUTE_PAIRS)
    if not pc.certified:
        return f"at scales {scale}: {pc.reason}"
    ch = loop_channels(design, b, box, u_eq=u_eq)
    keep = L.loop.keep
    Xk = X0[keep]
    # the candidate chosen for this start first: the LDI certificate's P (kept on a tie, as
    # when it came first) is passed over when no level it could reach (level_cap, NumPy)
    # gives a smaller V(start)/level than the other's (its ellipsoid SDPs could not win)
    cands = []
    wide = widest_start_p(L, ch, eps, gamma, rooms, Xk)
    if wide is not None:
        cands.append(("chosen for this start (LMI)", wide, 1))
    cands.append(("the LDI certificate's", np.asarray(pc.lyapunov[0][0], float), 0))
    best, notes = None, []
    for src, P, rank in cands:
        q = _contraction(ch, P)
        if not q < 1.0:
            notes.append(f"P {src}: ||M||_P = {q:.12f} >= 1 on the corners")
            continue
        kappa = 0.25 * (1.0 - q * q) / design.T
        if ch.K.shape[0] == 0 and not rooms and nbar == 0:
            from ._sector import Ellipsoid

            return (Ellipsoid(P, math.inf, kappa, 0.0, 0.0, -1.0), math.inf,
                    (f"the LDI certificate alone (||M||_P <= {q:.12f}, no limits, no region): "
                    f"global on {words}"), "every start, every plant of the class, no noise",
                    0.0)
        cap = math.inf if best is None else level_cap(ch, P, nbar=nbar, rooms=rooms)
        if best is not None and (not cap > 0 or float(Xk @ P @ Xk) / cap
                                 > best[1] * (1.0 + 1e-9)):  # the level reached is <= cap
            notes.append(f"P {src}: not solved (V(start)/level above the other P's at any "
                         "level it could reach)")
            continue
        E, ratio, note = solve_ellipsoid(ch, P, Xk, kappa=kappa, nbar=nbar, rooms=rooms)
        notes.append(f"P {src}: {note}")
        if E is not None and (best is None or ratio < best[1]
                              or (ratio == best[1] and rank < best[5])):
            best = (E, ratio, note, q, src, rank)
    if best is None:
        return f"at scales {scale}: " + "; ".join(notes)
    E, ratio, note, q, src, _ = best
    kappa = E.kappa
    # the largest step: same target, start y0 = r - s (the start's other parts fixed)
    d = np.zeros_like(Xk)
    d0 = X0.copy()
    d0[0] = 0.0
    d0[design.rho:design.rho + design.estimator.state_size] = 0.0
    Xc = d0[keep]
    d = (Xk - Xc) / max(abs(X0[0]), 1e-300)
    largest = _largest(E, Xc, d, 1.0)
    ult = E.ultimate_level()
    argument = (f"invariant ellipsoid V = X^T P X <= {E.level:.4g} (P {src}, "
                f"||M||_P <= {q:.12f} over the corners; decay kappa = {kappa:.3g} 1/s; sector multipliers for "
                f"{', '.join(ch.psi_names) or 'no limits'}; {note}) on {words}; "
                f"V(start)/level = {ratio:.4g}")
    covered = (f"every plant whose d sigma/d xi and b stay in the stated box, starts with "
               f"V(X0) <= {E.level:.4g} (this step: {ratio:.4g} of it), input saturation and "
               f"estimate clamps active or not"
               + (f", sensor noise |n| <= {nbar:g} (ultimate V <= {ult:.3g})" if nbar > 0
                  else ", no sensor noise"))
    return (E, largest, argument, covered, ratio)


def _contraction(ch, P) -> float:
    """``max_v ||M_v||_P`` over the corners (NumPy)."""
    Lc = np.linalg.cholesky((P + P.T) / 2)
    Li = np.linalg.inv(Lc)
    return max(float(np.linalg.norm(Lc.T @ M @ Li.T, 2)) for M in ch.Ms)


__all__ = ["StepCertificate", "certify_step"]
