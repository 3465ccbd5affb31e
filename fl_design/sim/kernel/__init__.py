"""The compiled closed-loop kernel: the loop as CasADi functions and the code that runs it.

Modules: ``_loop`` (:class:`ClosedLoop`: plant, design and integrator as CasADi functions, the
accumulating step ``fl_acc`` and the recording step ``fl_rec``), ``_emit`` (C for W grid
points per SIMD vector, emitted from ``fl_acc``'s instruction list), ``_vector`` (that C's
vector types, lane masks and math functions), ``_lanes`` (the lanes
runner, built for the CPU's instruction-set level), ``_runners`` (the scalar compiled runner and
CasADi's interpreter; :func:`make_runner` picks one), ``templates/`` (the C drivers).

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim.kernel import ClosedLoop
>>> loop = ClosedLoop(fl.plants.pendulum(), fl.presets.pendulum_design(), substeps=1)
>>> loop.runner(compiled=False).compiled
False
"""

from ._loop import ClosedLoop, accumulator_layout, default_substeps
from ._runners import make_runner

__all__ = ["ClosedLoop", "accumulator_layout", "default_substeps", "make_runner"]
