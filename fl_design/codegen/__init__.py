"""Code-generation layer: the loop step as embedded C, and the compiler/cache of the kernels.

Modules: ``_build`` (:func:`find_compiler`, :func:`build`, :func:`cache_directory`,
:func:`generate_source`, :data:`CFLAGS`, :data:`STRICT_CFLAGS`); ``_generate``
(:func:`generate_c`); ``_package`` (:class:`CPackage`); ``_float``
(:func:`to_single_precision`); ``_sil`` (:func:`software_in_the_loop`, :class:`SilResult`); ``_pil``
(:func:`processor_in_the_loop`, :class:`PilResult`: the step on a Cortex-M4F model);
``_graph`` (the step with its run-time parameter block); ``_emit`` (its C); ``_verdict`` (the C
loop's status);
``_cost`` (:class:`StepCost`, :class:`CostTable`, :func:`compare_costs`); ``_template``
(the C template files of ``templates/``).

Examples
--------
>>> from fl_design.codegen import STRICT_CFLAGS
>>> "-Werror" in STRICT_CFLAGS
True
"""

from ._build import CFLAGS, STRICT_CFLAGS, build, cache_directory, find_compiler, generate_source
from ._cost import CostTable, StepCost, compare_costs, operation_counts, step_cost
from ._float import mark_unused_parameters, to_single_precision
from ._generate import (
    PRECISIONS,
    check_precision,
    check_prefix,
    core_function,
    generate_c,
    step_design,
)
from ._package import CPackage, compiler_or_raise
from ._pil import PilResult, processor_in_the_loop
from ._sil import SilResult, software_in_the_loop

__all__ = ["CFLAGS", "PRECISIONS", "STRICT_CFLAGS", "CPackage", "CostTable", "PilResult",
           "SilResult",
           "StepCost", "build", "cache_directory", "check_precision", "check_prefix",
           "compare_costs", "compiler_or_raise", "core_function", "find_compiler",
           "generate_c", "generate_source", "mark_unused_parameters", "operation_counts",
           "processor_in_the_loop", "software_in_the_loop", "step_cost", "step_design", "to_single_precision"]
