"""Simulation layer: the sampled closed loop, its compiled kernel, ``simulate`` and ``sweep``.

Modules: ``_closed_loop`` (plant + design as CasADi functions, the accumulating step),
``_runners`` (compiled C driver or CasADi interpreter over samples and grid columns),
``_simulate`` (:func:`simulate`), ``_response`` (:class:`Response`, metrics, classification),
``_sweep`` (:func:`sweep`, :class:`StabilityMap`, :func:`estimate_eps_star`).

Examples
--------
>>> from fl_design.sim import STATUS_CODES
>>> sorted(STATUS_CODES)
['diverged', 'stable', 'undecided']
"""

from ._closed_loop import HUGE, AccumulatorLayout, ClosedLoop, accumulator_layout, default_substeps
from ._options import RK4, Classifier, Cvodes, Kernel, Noise, Scenario
from ._response import (
    METRIC_NAMES,
    STATUS_CODES,
    STATUS_NAMES,
    Response,
    classify,
    metrics_from_summary,
    summary_from_trajectories,
)
from ._runners import InterpretedRunner, NativeRunner, make_runner, runner_source
from ._simulate import RunSetup, default_divergence_bound, prepare_run, simulate
from ._sweep import EpsStarEstimate, StabilityMap, estimate_eps_star, run_grid, sweep

__all__ = [
    "HUGE",
    "METRIC_NAMES",
    "STATUS_CODES",
    "STATUS_NAMES",
    "RK4",
    "AccumulatorLayout",
    "Classifier",
    "Cvodes",
    "ClosedLoop",
    "EpsStarEstimate",
    "InterpretedRunner",
    "Kernel",
    "NativeRunner",
    "Noise",
    "Response",
    "RunSetup",
    "Scenario",
    "StabilityMap",
    "accumulator_layout",
    "classify",
    "default_divergence_bound",
    "default_substeps",
    "estimate_eps_star",
    "make_runner",
    "metrics_from_summary",
    "prepare_run",
    "run_grid",
    "runner_source",
    "simulate",
    "summary_from_trajectories",
    "sweep",
]
