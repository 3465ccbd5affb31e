"""``generate_c``: the observer-controller step of a design as a C99 package.

The C code is CasADi's code generation of :attr:`fl_design.Design.step` (the one loop-step
function; the loop is never written a second time) plus a small stateful wrapper from the
template files of ``fl_design/codegen/templates``: ``<prefix>.h`` / ``<prefix>.c`` (the API
``<prefix>_state_t``, ``<prefix>_init``, ``<prefix>_reset``, ``<prefix>_step`` and the design's
numbers as named constants), ``<prefix>_core.h`` / ``<prefix>_core.c`` (CasADi's code),
``main.c`` (the software-in-the-loop harness), ``Makefile`` and ``README.md``.

Single precision (``precision="float"``) is true single precision: the generated code is
rewritten by :func:`~fl_design.codegen.to_single_precision`, and an EHGO is realized in its
``"delta"`` form (:class:`fl_design.EHGO`, parameter ``realization``): the same input-output
map as the design's observer to round-off, but with ``A_d - I`` stored with its full relative
precision and a DC gain from ``y`` to the derivative estimates that is zero by construction. In
float the rounded direct matrices ``A_d`` (entries within ``1e-5`` of one at ``T = 1 ms``) keep
about two digits of ``A_d - I``.

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen import generate_c
>>> pkg = generate_c(presets.paper_design(), "trms_c")
>>> sorted(p.name for p in pkg.files)  # doctest: +NORMALIZE_WHITESPACE
['Makefile', 'README.md', 'fl.c', 'fl.h', 'fl_core.c', 'fl_core.h', 'main.c']
"""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path

import casadi as ca

from .._output import claim_output_folder, record_outputs
from ..design import EHGO, Design
from ..errors import OutputPathError, ParameterError
from ._float import mark_unused_parameters, to_single_precision
from ._package import CPackage

#: valid values of ``precision``
PRECISIONS = ("double", "float")
_C_KEYWORDS = frozenset(
    ["auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else", "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register", "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch", "typedef", "union", "unsigned", "void", "volatile", "while", "_Bool", "_Complex", "_Imaginary"])
_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


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
    >>> from fl_design.codegen import check_prefix
    >>> check_prefix("trms_yaw")
    'trms_yaw'
    """
    if (not isinstance(prefix, str) or not _IDENT.match(prefix) or prefix in _C_KEYWORDS
            or prefix.startswith("__") or re.match(r"_[A-Z]", prefix) or len(prefix) > 24):
        raise ParameterError(
            f"prefix={prefix!r} is not a usable C identifier: give 1 to 24 letters, digits or "
            "underscores, not starting with a digit, '__' or '_' + capital, and not a C "
            "keyword (e.g. 'fl' or 'trms_ctrl')")
    return prefix


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
    >>> from fl_design.codegen import check_precision
    >>> check_precision("float")
    'float'
    """
    if not isinstance(precision, str) or precision not in PRECISIONS:
        raise ParameterError(
            f"precision={precision!r} is not known; valid: {', '.join(map(repr, PRECISIONS))}")
    return precision


def step_design(design: Design, precision: str) -> Design:
    """The design whose ``step`` is generated: for ``"float"`` an EHGO goes to its delta form.

    Parameters
    ----------
    design : Design
        The user's design.
    precision : str
        ``"double"`` (the design as it is) or ``"float"``.

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
    if precision == "float" and isinstance(est, EHGO) and est.realization != "delta":
        return Design(estimator=est.replace(realization="delta"), controller=design.controller)
    return design


def generate_c(design: Design, out_dir, *, precision: str = "double",
               prefix: str = "fl", force: bool = False) -> CPackage:
    """Write the design's loop step as a C99 package (sources, header, harness, Makefile).

    Parameters
    ----------
    design : Design
        EHGO or least-squares design; its :attr:`~fl_design.Design.step` is generated.
    out_dir : path-like
        Folder to write (created if needed): empty, or holding this package's earlier output
        unchanged (:mod:`fl_design._output`); a folder with other files is refused.
    precision : {"double", "float"}, optional
        ``"float"``: true single precision everywhere (literals, math calls, API), with the
        EHGO in its delta realization (module docstring).
    prefix : str, optional
        Prefix of the C names and files (default ``"fl"``): ``fl_step``, ``fl_state_t``,
        ``fl.h``.
    force : bool, optional
        Write into ``out_dir`` even when it holds files fl_design did not write (they may be
        replaced).

    Returns
    -------
    CPackage
        The files, with ``verify`` (software-in-the-loop) and ``cost``.

    Raises
    ------
    ParameterError
        Unknown ``precision``, ``prefix`` not a C identifier, ``design`` not a Design.
    OutputPathError
        ``out_dir`` cannot be created or written.
    OutputExistsError
        ``out_dir`` holds files fl_design did not write (or edited since) and ``force`` is
        False.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> pkg = generate_c(presets.paper_design(), "c_float", precision="float", prefix="trms")
    >>> "float trms_step(trms_state_t *s, float y, float r);" in (pkg.out_dir / "trms.h").read_text()
    True
    """
    precision, prefix = check_precision(precision), check_prefix(prefix)
    if not isinstance(design, Design):
        raise ParameterError(f"design must be a fl.Design, got {type(design).__name__}")
    used = step_design(design, precision)
    out = claim_output_folder(out_dir, force=force, what="out_dir")
    try:
        files = _write_core(used, out, precision, prefix)
        files += _write_templates(used, out, precision, prefix)
        record_outputs(out, files)
    except OSError as exc:
        raise OutputPathError(f"cannot write the C package into {str(out)!r}: {exc}") from None
    return CPackage(out_dir=out, design=design, step_design=used, precision=precision,
                    prefix=prefix, files=tuple(files))


def core_function(design: Design, prefix: str) -> ca.Function:
    """``<prefix>_step_core``: :attr:`Design.step` under the name the C code uses.

    The graph is ``design.step`` called on fresh symbols (inlined: the same instructions).

    Parameters
    ----------
    design : Design
        The design.
    prefix : str
        C prefix.

    Returns
    -------
    casadi.Function

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import core_function
    >>> core_function(presets.paper_design(), "fl").name()
    'fl_step_core'
    """
    f = design.step
    state, y, r = ca.SX.sym("state", f.nnz_in(0)), ca.SX.sym("y"), ca.SX.sym("r")
    return ca.Function(f"{prefix}_step_core", [state, y, r], f(state, y, r),
                       ["state", "y", "r"], ["state_next", "u"])


def _write_core(design: Design, out: Path, precision: str, prefix: str) -> list[Path]:
    opts = {"with_header": True, "casadi_real": precision, "casadi_int": "int",
            "with_export": False, "verbose": False}
    cg = ca.CodeGenerator(f"{prefix}_core.c", opts)
    cg.add(core_function(design, prefix))
    cg.generate(str(out) + "/")
    c_file, h_file = out / f"{prefix}_core.c", out / f"{prefix}_core.h"
    text = mark_unused_parameters(c_file.read_text())
    c_file.write_text(to_single_precision(text) if precision == "float" else text)
    return [c_file, h_file]


def _write_templates(design: Design, out: Path, precision: str, prefix: str) -> list[Path]:
    from ._template import render, substitutions

    subs = substitutions(design, precision, prefix)
    names = {"step.h.in": f"{prefix}.h", "step.c.in": f"{prefix}.c", "main.c.in": "main.c",
             "Makefile.in": "Makefile", "README.md.in": "README.md"}
    written = []
    for template, name in names.items():
        text = resources.files("fl_design.codegen").joinpath("templates", template).read_text()
        path = out / name
        path.write_text(render(text, subs))
        written.append(path)
    return written


__all__ = ["PRECISIONS", "check_precision", "check_prefix", "core_function", "generate_c",
           "step_design"]
