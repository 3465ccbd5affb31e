"""Filling the C template files: ``@NAME@`` placeholders and the design's named constants.

Examples
--------
>>> from fl_design.codegen._template import render
>>> render("float @PREFIX@_step(void);", {"PREFIX": "fl"})
'float fl_step(void);'
"""

from __future__ import annotations

import re

import casadi as ca

from ..design import EHGO, Design, LeastSquaresEstimator
from ..errors import ComputationError


def render(text: str, subs: dict[str, str]) -> str:
    """Replace every ``@KEY@`` of ``subs`` in ``text``; a placeholder left over is an error.

    Parameters
    ----------
    text : str
        Template text.
    subs : dict
        ``{KEY: value}``.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.codegen._template import render
    >>> render("@A@ and $@", {"A": "x"})
    'x and $@'
    """
    for key, value in subs.items():
        text = text.replace(f"@{key}@", value)
    left = re.findall(r"@[A-Z][A-Z0-9_]*@", text)
    if left:
        raise ComputationError(f"template placeholders without a value: {sorted(set(left))}")
    return text


def c_literal(x: float, precision: str) -> str:
    """A C floating literal of ``x`` (``f``-suffixed in single precision).

    Parameters
    ----------
    x : float
        Finite value.
    precision : str
        ``"double"`` or ``"float"``.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.codegen._template import c_literal
    >>> c_literal(1e-3, "float"), c_literal(-2.0, "double")
    ('0.001f', '-2.0')
    """
    text = repr(float(x))
    return text + "f" if precision == "float" else text


def _constants(design: Design, precision: str, P: str) -> list[str]:
    lit = lambda x: c_literal(x, precision)
    ctrl, est = design.controller, design.estimator
    rows = [(f"{P}_T", lit(design.T), "sampling time (s): call the step at this period"),
            (f"{P}_RHO", str(design.rho), "relative degree served"),
            (f"{P}_GAMMA", lit(ctrl.gamma), "controller gain gamma"),
            (f"{P}_KI", lit(ctrl.ki), "integral gain k_I")]
    rows += [(f"{P}_K{i + 1}", lit(k), f"gain k_{i + 1}") for i, k in enumerate(ctrl.gains)]
    if ctrl.u_range is not None:
        rows += [(f"{P}_U_MIN", lit(ctrl.u_range[0]), "input saturation, low"),
                 (f"{P}_U_MAX", lit(ctrl.u_range[1]), "input saturation, high")]
    for i, lim in enumerate(ctrl.estimate_ranges):
        if lim is not None:
            rows += [(f"{P}_XHAT{i + 1}_MIN", lit(lim[0]), f"clamp of xhat_{i + 1}, low"),
                     (f"{P}_XHAT{i + 1}_MAX", lit(lim[1]), f"clamp of xhat_{i + 1}, high")]
    if isinstance(est, EHGO):
        rows += [(f"{P}_EPS", lit(est.eps), "EHGO time constant eps (s)")]
        rows += [(f"{P}_ALPHA{i + 1}", lit(a), f"EHGO coefficient alpha_{i + 1}")
                 for i, a in enumerate(est.alphas)]
    elif isinstance(est, LeastSquaresEstimator):
        rows += [(f"{P}_WINDOW", str(est.window), "least-squares window (samples)"),
                 (f"{P}_FIT_DEGREE", str(est.fit_degree), "least-squares polynomial degree")]
    width = max(len(name) for name, _, _ in rows)
    return [f"#define {name:<{width}} {value:<24} /* {what} */" for name, value, what in rows]


def substitutions(design: Design, precision: str, prefix: str) -> dict[str, str]:
    """Every placeholder value of the templates for ``design``.

    Parameters
    ----------
    design : Design
        The design generated (after :func:`~fl_design.codegen.step_design`).
    precision : str
        ``"double"`` or ``"float"``.
    prefix : str
        C prefix.

    Returns
    -------
    dict

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._template import substitutions
    >>> substitutions(presets.paper_design(), "double", "fl")["STATE_SIZE"]
    '5'
    """
    import fl_design

    P = prefix.upper()
    lay = design.state_layout
    f = design.step
    sz_iw, sz_w = int(f.sz_iw()), int(f.sz_w())
    decl = []
    if sz_iw:
        decl.append(f"  int iw[{sz_iw}];")
    if sz_w:
        decl.append(f"  {precision} w[{sz_w}];")
    init = ", ".join(c_literal(v, precision) for v in design.initial_state())
    size = 4 if precision == "float" else 8
    return {
        "PREFIX": prefix, "P": P, "REAL": precision, "PRECISION": precision,
        "VERSION": fl_design.__version__, "CASADI_VERSION": ca.__version__,
        "DESCRIPTION": " ".join(repr(design).split()),
        "CONSTANTS": "\n".join(_constants(design, precision, P)),
        "STATE_SIZE": str(design.state_size), "ESTIMATOR_SIZE": str(lay["estimator"].stop),
        "U_INDEX": str(lay["u"].start), "Z_INDEX": str(lay["z"].start),
        "INITIAL_STATE": init, "WORK_DECL": "\n".join(decl) or "  /* no work arrays */",
        "WORK_ARGS": f"{'iw' if sz_iw else '0'}, {'w' if sz_w else '0'}",
        "EXTRA_WARNINGS": "-Wdouble-promotion -Wfloat-conversion" if precision == "float" else "",
        "FLOAT_NOTE": (", and `-Wdouble-promotion -Wfloat-conversion` clean: single precision "
                       "only (float literals, `fmaxf`-family calls)" if precision == "float"
                       else ""),
        "STATE_BYTES": str(size * design.state_size),
        "RATE": (f"{1e-3 / design.T:g} kHz" if design.T <= 1e-3 else f"{1.0 / design.T:g} Hz"),
        "T": f"{design.T:g}",
    }


__all__ = ["c_literal", "render", "substitutions"]
