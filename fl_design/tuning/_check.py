"""The checks of a tuned design (:func:`fl_design.tune`): a simulation, a short sweep, noise.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.tuning._check import check_candidate
>>> c = check_candidate(fl.plants.pendulum(), fl.presets.pendulum_design(), 0.1)
>>> c["status"], c["sweep_ok"], len(c["sweep"])
('converged', 6, 6)
"""

from __future__ import annotations

import math

from ..analysis import noise_gain
from ..errors import FlDesignError
from ..sim import Scenario, simulate

#: The short sweep around a design: eps and |gamma| factors.
SWEEP_EPS = (0.5, 1.0)
SWEEP_GAMMA = (0.5, 1.0, 2.0)
CONVERGENT = ("converged", "converging")
#: the default step of a tuning's check, as a fraction of the output's range
STEP_FRACTION = 0.05


def step_target(y0: float, y_range: tuple[float, float]) -> float:
    """The default reference of a tuning's check: a step of :data:`STEP_FRACTION` of the
    output's range from ``y0``, up, or down when up would leave the range.

    Parameters
    ----------
    y0 : float
        The output at the operating point.
    y_range : (float, float)
        The output's range (the plant region's, or the class's ``y_range``).

    Returns
    -------
    float

    Examples
    --------
    >>> from fl_design.tuning._check import step_target
    >>> step_target(0.0, (-1.0, 1.0)), step_target(1.0, (-1.0, 1.0))
    (0.1, 0.9)
    """
    lo, hi = y_range
    step = STEP_FRACTION * (hi - lo)
    return float(y0 + step if y0 + step <= hi else y0 - step)


def check_candidate(plant, design, r: float) -> dict:
    """Simulate a step to ``r``, sweep around the design, and its noise gain.

    Parameters
    ----------
    plant : Plant
        The plant.
    design : Design
        The candidate.
    r : float
        Step target.

    Returns
    -------
    dict
        ``status``, ``overshoot`` (%), ``settling_time`` (s), ``response``, ``noise_gain``
        (inf when the loop at ``r`` is not stable, NaN when its equilibrium is not found),
        ``noise_note`` (None, or how the noise gain was computed instead), ``sweep``
        (``(eps, gamma, status)`` per run), ``sweep_ok`` (how many converge).

    Examples
    --------
    See the module.
    """
    resp = simulate(plant, design, Scenario(r))
    out = {"status": resp.status, "overshoot": float(resp.overshoot),
           "settling_time": float(resp.settling_time), "response": resp,
           "noise_gain": math.inf, "noise_note": None, "sweep": (), "sweep_ok": 0}
    if resp.status not in CONVERGENT:
        return out
    out["noise_gain"], out["noise_note"] = _noise(plant, design, r)
    eps, gamma = design.estimator.eps, design.controller.gamma
    # the short sweep: single runs of the same compiled step (eps and gamma are run-time
    # parameters), no grid kernel to build for six runs
    runs = tuple((float(e), float(g), str(simulate(
                  plant, design.replace(eps=e, gamma=g), Scenario(r, resp.duration)).status))
                 for e in (eps * f for f in SWEEP_EPS)
                 for g in sorted(gamma * f for f in SWEEP_GAMMA))
    out["sweep"], out["sweep_ok"] = runs, sum(s in CONVERGENT for *_, s in runs)
    return out


def _noise(plant, design, r: float) -> tuple[float, str | None]:
    """The noise gain at ``r``; fallback: at the operating point's output (NaN and the reason
    when the loop's equilibrium is found at neither)."""
    try:
        return noise_gain(plant, design, r=r), None
    except FlDesignError as exc:
        first = str(exc).splitlines()[0][:160]
    try:
        return noise_gain(plant, design), (f"noise gain at the operating point (at r = {r:.6g}: "
                                           f"{first})")
    except FlDesignError as exc:
        return math.nan, (f"noise gain not computed: no loop equilibrium found at r = {r:.6g} "
                          f"({first}) nor at the operating point ({str(exc)[:120]})")


def baseline_for(plant, baseline, r: float) -> dict | None:
    """The comparison design's noise gain and step response (None: no baseline).

    ``"auto"``: the paper's design for the library TRMS (``trms_yaw`` without motor lag).

    Parameters
    ----------
    plant : Plant
        The plant.
    baseline : Design, None or "auto"
        The design to compare.
    r : float
        Step target.

    Returns
    -------
    dict or None
        ``name``, ``noise_gain``, ``overshoot`` (%), ``status``.

    Examples
    --------
    >>> import fl_design as fl
    >>> baseline_for(fl.plants.trms_yaw(), "auto", 0.3)["name"]
    "the paper's design (eps 0.05, gamma 3e-4, T 1 ms)"
    """
    from .. import presets
    from ..design import Design
    from ..errors import ParameterError

    if baseline is None:
        return None
    if isinstance(baseline, str) and baseline == "auto":
        if plant.name != "trms_yaw" or plant.relative_degree() != 2:
            return None
        baseline, name = presets.paper_design(), "the paper's design (eps 0.05, gamma 3e-4, T 1 ms)"
    elif isinstance(baseline, Design):
        name = "the given baseline"
    else:
        raise ParameterError(f"baseline={baseline!r}: give a Design, None or 'auto'")
    resp = simulate(plant, baseline, Scenario(r))
    return {"name": name, "noise_gain": _noise(plant, baseline, r)[0],
            "overshoot": float(resp.overshoot), "status": resp.status}


__all__ = ["STEP_FRACTION", "baseline_for", "check_candidate", "step_target"]
