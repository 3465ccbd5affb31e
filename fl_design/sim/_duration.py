"""The run length a :class:`~fl_design.Scenario` without ``duration`` gets: from the loop itself.

``fl.Scenario(r)`` (``duration`` omitted) lets the run choose its length from the slowest time
constant of the sampled loop linearized at the design point and the reference
(:class:`~fl_design.sim.LoopLinearizer`: the slowest *coupled* eigenvalue ``lambda``, the
decoupled integrator of ``ki = 0`` excluded)::

    tau = -T / ln|lambda|,        duration = multiple * tau,
    multiple = ln(AMPLITUDE / tolerance) / (1 - tail_fraction)

Why this multiple: :class:`~fl_design.Classifier` calls a run *converged* when the error stays
inside the band ``tolerance * |step|`` over the whole tail, the last ``tail_fraction`` of the
run. The slowest mode's error ``A |step| exp(-t / tau)`` is inside the band from
``t = tau ln(A / tolerance)`` on, and the tail starts at ``(1 - tail_fraction) duration``.
``A`` = :data:`AMPLITUDE` = 10 lets that mode start at up to 10 times the step (overshoot,
several modes adding up; the pendulum bench design's slow mode starts at 1.1 times its step).
With the default classifier (2 %, tail 0.2) the multiple is ``ln(500) / 0.8 = 7.77``. A loop
that decays like its linearization is then converged well inside the run, one that is
converging shows a decaying envelope over the run's second half (by ``exp(-0.5 duration /
tau)``, far beyond :data:`~fl_design.sim._status.MIN_CHANGE`), and an oscillating one has had
7.8 time constants to settle and did not.

The length is clamped to ``[MIN_SAMPLES, MAX_SAMPLES]`` samples (and to
``$FL_DESIGN_MAX_SAMPLES``), saying so: at least :data:`MIN_SAMPLES` for the tail windows to
hold enough samples, at most :data:`MAX_SAMPLES` (300 s at ``T = 1 ms``: a recorded run of
about 40 MB). When the linearized loop has no stable equilibrium (spectral radius >= 1, or none
found) the run gets the fixed :data:`FALLBACK_DURATION` (clamped the same way), and the reason
says why. The reference of the linearization is the scenario's constant reference; for a
callable ``r(t)`` it is the output at the plant's operating point (the reference's own timing
is not known: give ``duration`` for a time-varying reference).

A sweep and :func:`~fl_design.estimate_eps_star` resolve the length once, at the design's own
``(eps, gamma)``, and run every grid point or candidate that long (one length per map: the
classification of every point uses the same tail window).

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim._duration import resolve_duration
>>> loop = fl.sim.ClosedLoop(fl.plants.pendulum(), fl.presets.pendulum_design(), substeps=4)
>>> length = resolve_duration(loop, fl.Scenario(0.1), fl.Classifier())
>>> round(length.duration, 2), length.reason
(17.55, '7.77 x tau = 2.26 s (slowest mode of the loop linearized at r = 0.1, eps = 0.02, gamma = 0.01)')
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ComputationError
from ._loop_jacobian import LoopLinearizer
from ._scenario import max_samples

#: Largest initial amplitude, relative to the step, the slowest mode is allowed to start with.
AMPLITUDE = 10.0
#: Fewest samples of an adaptive run.
MIN_SAMPLES = 1000
#: Most samples of an adaptive run (before ``$FL_DESIGN_MAX_SAMPLES``).
MAX_SAMPLES = 300_000
#: Run length (s) when the linearized loop has no stable equilibrium.
FALLBACK_DURATION = 20.0


@dataclass(frozen=True)
class RunLength:
    """The length of a run and why.

    Parameters
    ----------
    duration : float
        Seconds (``N T``).
    reason : str
        ``"given"``, or how the adaptive length was chosen: ``"7.77 x tau = ... (slowest
        mode ...)"``, ``"clamped to ..."``, ``"raised to the minimum ..."``, ``"fixed 20 s:
        ..."`` (no stable equilibrium).
    tau : float or None
        The slowest time constant used (None: given or fallback).

    Examples
    --------
    >>> from fl_design.sim._duration import RunLength
    >>> RunLength(20.0, "given", None).adaptive
    False
    """

    duration: float
    reason: str
    tau: float | None

    @property
    def adaptive(self) -> bool:
        """The length was chosen by the run, not given."""
        return self.reason != "given"


def duration_multiple(classifier) -> float:
    """``ln(AMPLITUDE / tolerance) / (1 - tail_fraction)``: time constants per run.

    Parameters
    ----------
    classifier : Classifier
        Tolerance and tail window of the classification.

    Returns
    -------
    float
        ``inf`` when the tail is the whole run (``tail_fraction = 1``).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._duration import duration_multiple
    >>> round(duration_multiple(fl.Classifier()), 3)
    7.768
    """
    tail = float(classifier.tail_fraction)
    if tail >= 1.0:
        return math.inf
    return math.log(AMPLITUDE / float(classifier.tolerance)) / (1.0 - tail)


def _bounds() -> tuple[int, int]:
    hi = min(MAX_SAMPLES, max_samples())
    return min(MIN_SAMPLES, hi), hi


def _reference(loop, scenario) -> tuple[float, str]:
    ref = scenario.reference
    if callable(ref):
        y = float(loop.plant.casadi().h(loop.plant.x_op))
        return y, f"r = {y:.4g}, the operating point's output (callable reference)"
    return float(ref), f"r = {float(ref):.4g}"


def resolve_duration(loop, scenario, classifier) -> RunLength:
    """The run length of ``scenario`` on ``loop``: as given, or from the loop (module text).

    Parameters
    ----------
    loop : ClosedLoop
        Plant, design (its own ``eps`` and ``gamma``) and integrator.
    scenario : Scenario
        ``duration`` None means adaptive.
    classifier : Classifier
        Its tolerance and tail window set the multiple of ``tau``.

    Returns
    -------
    RunLength
        The duration and how it was chosen (``reason``, and the ``tau`` it came from).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import ClosedLoop
    >>> from fl_design.sim._duration import resolve_duration
    >>> loop = ClosedLoop(fl.plants.pendulum(), fl.presets.pendulum_design(), substeps=4)
    >>> resolve_duration(loop, fl.Scenario(0.1, 5.0), fl.Classifier())
    RunLength(duration=5.0, reason='given', tau=None)
    """
    if scenario.duration is not None:
        return RunLength(float(scenario.duration), "given", None)
    T = loop.T
    lo, hi = _bounds()
    r, where = _reference(loop, scenario)
    design = loop.design
    point = (f"eps = {design.estimator.eps:g}, " if design.estimator.has_time_constant else "")
    point += f"gamma = {design.controller.gamma:g}"
    try:
        lin = LoopLinearizer(loop)(r, design.parameter_vector())
    except ComputationError:
        lin, why = None, (f"no equilibrium holding {where} ({point}); "
                          "fl.sampled_linearization at this reference says why")
    if lin is not None and not lin.stable:
        why = (f"the loop linearized at {where} ({point}) is unstable (spectral radius "
               f"{lin.spectral_radius:.6g} >= 1)")
    if lin is None or not lin.stable:
        N = int(np.clip(round(FALLBACK_DURATION / T), lo, hi))
        return RunLength(N * T, f"fixed {N * T:g} s: {why}", None)
    tau = lin.slowest_time_constant
    multiple = duration_multiple(classifier)
    wanted = multiple * tau
    mode = (f"{multiple:.3g} x tau = {tau:.3g} s (slowest mode of the loop linearized at "
            f"{where}, {point})")
    N = math.ceil(wanted / T) if math.isfinite(wanted) else math.inf
    if N > hi:
        return RunLength(hi * T, (f"clamped to {hi * T:g} s ({hi} samples, the adaptive "
                                  f"maximum): {mode} would be {wanted:.3g} s; give duration= "
                                  "to run longer"), tau)
    if N < lo:
        return RunLength(lo * T, (f"raised to the minimum {lo * T:g} s ({lo} samples for the "
                                  f"tail windows): {mode} is {wanted:.3g} s"), tau)
    return RunLength(N * T, mode, tau)


__all__ = ["AMPLITUDE", "FALLBACK_DURATION", "MAX_SAMPLES", "MIN_SAMPLES", "RunLength",
           "duration_multiple", "resolve_duration"]
