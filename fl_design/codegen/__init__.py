"""Code-generation layer: the loop step as embedded C, verified in and on the loop.

Public API: :func:`generate_c` -> :class:`CPackage` (``.verify()``: closed-loop SIL ->
:class:`SilResult`; ``.pil()``: Cortex-M4F model -> :class:`PilResult`; ``.cost()``), the
cost tables (:class:`StepCost`, :class:`CostTable`, :func:`compare_costs`,
:func:`operation_counts`, :func:`step_cost`), the step being generated (:func:`step_design`,
:func:`core_function`), :func:`to_single_precision`, :data:`PRECISIONS` and the strict flag set
:data:`STRICT_CFLAGS` the packages are tested with.

Modules: ``_generate`` (:func:`generate_c`); ``_package`` (:class:`CPackage`); ``_graph``
(the step with its run-time parameter block); ``_emit`` (its C); ``_float``
(:func:`to_single_precision`); ``_float_check`` (the float build's predicted error);
``_compare`` (a step's inputs against ``Design.step``'s on the same record); ``_sil``
and ``_verdict`` (closed-loop SIL, the C loop's status); ``_pil`` (the Cortex-M4F model);
``_cost``; ``_template`` (the C files of ``templates/``); ``_guard`` (the checks' defaults,
the design hash, a Python model of the guard); ``_vectors`` (the test-vector file);
``_misra`` (the deviation report); ``_telemetry`` (:func:`read_telemetry`); ``_episode``
(the SIL's saturation episode, :meth:`CPackage.saturation_episode`); ``_pil_q31`` (the Q31
step on the Cortex-M3 and M0+ models). The compiler, its flag sets and the
cache are the ground floor's (:mod:`fl_design._toolchain`).

Examples
--------
>>> from fl_design.codegen import STRICT_CFLAGS
>>> "-Werror" in STRICT_CFLAGS
True
"""

from .._toolchain import STRICT_CFLAGS
from ._compare_costs import compare_costs
from ._cost import CostTable, StepCost, operation_counts, step_cost
from ._float import to_single_precision
from ._generate import PRECISIONS, core_function, generate_c, step_design
from ._package import CPackage
from ._pil import PilResult, processor_in_the_loop
from ._sil import SilResult, software_in_the_loop
from ._telemetry import Telemetry, read_telemetry

__all__ = [
           "PRECISIONS",
           "STRICT_CFLAGS",
           "CPackage",
           "CostTable",
           "PilResult",
           "SilResult",
           "StepCost",
           "Telemetry",
           "compare_costs",
           "core_function",
           "generate_c",
           "operation_counts",
           "processor_in_the_loop",
           "read_telemetry",
           "software_in_the_loop",
           "step_cost",
           "step_design",
           "to_single_precision",
]
