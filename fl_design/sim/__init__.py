"""Simulation layer: the sampled closed loop, its compiled kernel, ``simulate`` and ``sweep``.

Modules: ``_options`` (run options: :class:`Scenario`, :class:`Noise`, :class:`Classifier`,
:class:`RK4`, :class:`Cvodes`, :class:`Kernel`), ``_metrics`` (the one table of a run's
accumulators and metrics), ``_status`` (:class:`Status` and :func:`classify`: how a run is
classified), ``_closed_loop`` (plant + design as CasADi functions, the accumulating step), ``_runners`` (compiled C driver or CasADi interpreter),
``_run`` (:func:`prepare_run`), ``_simulate`` (:func:`simulate`), ``_response``
(:class:`Response`), ``_grid`` (chunks over threads/executors), ``_sweep`` (:func:`sweep`,
:func:`estimate_eps_star`), ``_stability_map`` (:class:`StabilityMap`), ``_linearize`` (the
loop's equilibrium and Jacobian, :class:`LoopLinearizer`, :class:`SampledLinearization`; the
public :func:`fl_design.sampled_linearization` is in ``analysis``).

Examples
--------
>>> from fl_design.sim import STATUS_CODES
>>> sorted(STATUS_CODES)
['converged', 'converging', 'diverged', 'oscillating', 'solver_failed', 'stalled', 'undecided']
"""

from ._closed_loop import HUGE, ClosedLoop, accumulator_layout, default_substeps
from ._grid import CHUNK_IN_PROCESS, CHUNK_PER_TASK, parameter_columns, run_grid
from ._linearize import LoopLinearizer, SampledLinearization
from ._metrics import (
    ACCUMULATORS,
    METRIC_NAMES,
    METRICS,
    RUN_CONSTANTS,
    STATUS_CODES,
    STATUS_NAMES,
    Accumulator,
    Metric,
    Status,
    classify,
    initial_values,
    metric_layout,
    metrics_from_summary,
    signals,
    update,
)
from ._options import RK4, Classifier, Cvodes, Kernel, Noise, Scenario
from ._response import Response
from ._run import RunSetup, default_divergence_bound, prepare_run
from ._simulate import simulate
from ._stability_map import EpsStar, EpsStarEstimate, StabilityMap
from ._sweep import estimate_eps_star, sweep

__all__ = [
    "ACCUMULATORS",
    "CHUNK_IN_PROCESS",
    "CHUNK_PER_TASK",
    "HUGE",
    "METRICS",
    "METRIC_NAMES",
    "RK4",
    "RUN_CONSTANTS",
    "STATUS_CODES",
    "STATUS_NAMES",
    "Accumulator",
    "Classifier",
    "ClosedLoop",
    "Cvodes",
    "EpsStar",
    "EpsStarEstimate",
    "Kernel",
    "LoopLinearizer",
    "Metric",
    "Noise",
    "Response",
    "RunSetup",
    "SampledLinearization",
    "Scenario",
    "StabilityMap",
    "Status",
    "accumulator_layout",
    "classify",
    "default_divergence_bound",
    "default_substeps",
    "estimate_eps_star",
    "initial_values",
    "metric_layout",
    "metrics_from_summary",
    "parameter_columns",
    "prepare_run",
    "run_grid",
    "signals",
    "simulate",
    "sweep",
    "update",
]
