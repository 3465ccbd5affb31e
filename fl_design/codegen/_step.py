"""What is generated: the checked precision and prefix, the design whose step becomes C.

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen._step import core_function
>>> core_function(presets.paper_design(), "fl").name()
'fl_step_core'
"""

from __future__ import annotations

import re

import casadi as ca

from ..design import EHGO, Design
from ..errors import ParameterError

#: valid values of ``precision``
PRECISIONS = ("double", "float", "q31")
_C_KEYWORDS = frozenset(
    ["auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else", "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register", "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch", "typedef", "union", "unsigned", "void", "volatile", "while", "_Bool", "_Complex", "_Imaginary"])
_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


#: The generated package's files that a prefix's ``<prefix>.c`` / ``<prefix>.h`` must not name.
PACKAGE_FILES = ("main.c", "check.c", "sil.c", "Makefile", "CMakeLists.txt", "README.md",
                 "test_vectors.txt", "MISRA_DEVIATIONS.md")


def check_prefix(prefix) -> str:
    """``prefix`` if it is a usable C identifier, else ParameterError saying what is valid.

    Parameters
    ----------
    prefix : str
        Prefix of every public C name (``<prefix>_step``, ``<prefix>_state_t``...).

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.codegen._generate import check_prefix
    >>> check_prefix("trms_yaw")
    'trms_yaw'
    """
    if (not isinstance(prefix, str) or not _IDENT.match(prefix) or prefix in _C_KEYWORDS
            or prefix.startswith("__") or re.match(r"_[A-Z]", prefix) or len(prefix) > 24):
        raise ParameterError(
            f"prefix={prefix!r} is not a usable C identifier: give 1 to 24 letters, digits or "
            "underscores, not starting with a digit, '__' or '_' + capital, and not a C "
            "keyword (e.g. 'fl' or 'trms_ctrl')")
    from .._output import check_prefix_names

    # the package's own files: a prefix naming one of them (``main`` -> main.c) would overwrite
    # it with the step's source and the package would not link
    return check_prefix_names(prefix, PACKAGE_FILES)


def check_precision(precision) -> str:
    """``precision`` if it is ``"double"`` or ``"float"``, else ParameterError.

    Parameters
    ----------
    precision : str
        Floating-point type of the generated code.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.codegen._generate import check_precision
    >>> check_precision("float")
    'float'
    """
    if not isinstance(precision, str) or precision not in PRECISIONS:
        raise ParameterError(
            f"precision={precision!r} is not known; valid: {', '.join(map(repr, PRECISIONS))}")
    return precision


def step_design(design: Design, precision: str) -> Design:
    """The design whose ``step`` is generated: an EHGO goes to its delta form.

    In ``"float"`` the delta form is computed about the last sample, as a recursion
    (:class:`fl_design.codegen._float_realize.LevelFreeEHGO`): no stored value carries the
    output's level, whose rounding the observer would amplify by ``~1 / eps^rho``.

    Parameters
    ----------
    design : Design
        The user's design.
    precision : str
        ``"double"``, ``"float"`` or ``"q31"``.

    Returns
    -------
    Design

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import step_design
    >>> step_design(presets.paper_design(), "float").estimator.realization
    'delta'
    """
    est = design.estimator
    if isinstance(est, EHGO) and est.realization != "delta":
        design = Design(estimator=est.replace(realization="delta"), controller=design.controller)
    if precision == "float":
        from ._float_realize import level_free

        return level_free(design)
    return design


def core_function(design: Design, prefix: str) -> ca.Function:
    """``<prefix>_step_core(x, y, r, p) -> (x_next, u)``: the function the C core computes.

    :attr:`Design.step` with the controller's numbers as the run-time parameter block ``p``
    (:func:`fl_design.codegen._graph.parametric_core`).

    Parameters
    ----------
    design : Design
        The design generated (after :func:`step_design`).
    prefix : str
        C prefix.

    Returns
    -------
    casadi.Function

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import core_function
    >>> core_function(presets.paper_design(), "fl").name_in()
    ['x', 'y', 'r', 'p']
    """
    from ._graph import parametric_core

    return parametric_core(design, f"{prefix}_step_core")


__all__ = ["PRECISIONS", "check_precision", "check_prefix", "core_function", "step_design"]
