"""Simulation layer: the sampled closed loop, ``simulate`` and ``sweep``.

Public API (re-exported at ``fl_design``): run options :class:`Scenario`, :class:`Noise`,
:class:`Classifier`, :class:`RK4`, :class:`Cvodes`, :class:`Kernel`, :class:`Disturbance`
(:class:`Step`, :class:`Sine`); :func:`simulate` ->
:class:`Response`; :func:`sweep` -> :class:`StabilityMap`; :func:`estimate_eps_star` ->
:class:`EpsStarEstimate`; :class:`EpsStar` brackets; :func:`monte_carlo` over a family of
plants (``fl.Uniform``, ``fl.Normal``) -> ``fl.Ensemble``, and ``sweep(..., params=)`` ->
``fl.RobustMap`` (those four imported from their modules: ``_family``, ``_ensemble``,
``_robust_map``); :class:`Status` and its codes; the
:class:`ClosedLoop` for advanced use.

Modules, one concept each: ``_scenario`` and ``_options`` (the option objects), ``_metrics``
(the one table of a run's accumulators and metrics), ``_status`` (how a run is classified),
``_run`` (:func:`prepare_run`: samples and constants of a run), ``_duration`` (the adaptive
run length), ``_loop_jacobian`` (the loop's equilibrium and Jacobian), ``_simulate`` and
``_response``, ``_grid`` (many runs in this process) and ``_executor`` (as tasks of an
executor), ``_sweep`` and ``_stability_map`` (its eps*: ``_eps_star``); ``_family`` (a family of plants: distributions and the
per-sample setup), ``_monte_carlo`` and ``_ensemble``, ``_robust_map`` (their figures: :mod:`fl_design.plotting`); ``_partial`` (what a grid gives
when a worker dies: ``PartialStabilityMap``, ``PartialRobustMap``, ``PartialEnsemble``,
subclasses of the three results that add a ``lost`` mask; only received, in
``WorkerLostError.partial``, never constructed by a user, so not exported here: a layer exports
at most 20 names); the compiled kernel in the subpackage
:mod:`fl_design.sim.kernel`. Helpers other layers need are imported from their module.

Examples
--------
>>> from fl_design.sim import STATUS_CODES
>>> sorted(STATUS_CODES)
['converged', 'converging', 'diverged', 'oscillating', 'solver_failed', 'stalled', 'undecided']
"""

from ._disturbance import Disturbance, Sine, Step
from ._eps_star import EpsStar
from ._metrics import STATUS_CODES, Status
from ._monte_carlo import monte_carlo
from ._options import RK4, Classifier, Cvodes, Kernel, Noise, Scenario
from ._response import Response
from ._simulate import simulate
from ._stability_map import EpsStarEstimate, StabilityMap
from ._sweep import estimate_eps_star, sweep
from .kernel import ClosedLoop

__all__ = [
    "RK4",
    "STATUS_CODES",
    "Classifier",
    "ClosedLoop",
    "Cvodes",
    "Disturbance",
    "EpsStar",
    "EpsStarEstimate",
    "Kernel",
    "Noise",
    "Response",
    "Scenario",
    "Sine",
    "StabilityMap",
    "Status",
    "Step",
    "estimate_eps_star",
    "monte_carlo",
    "simulate",
    "sweep",
]
