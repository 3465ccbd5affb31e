"""Predicting the single-precision build's error before it is written.

:func:`emulate` runs the generated step's arithmetic (the instruction list
:mod:`fl_design.codegen._emit` prints, in the same order) with every operation rounded to IEEE
single precision (NumPy ``float32``), as the C compiled with ``-std=c99`` (no contraction)
computes it. :func:`predict_float_error` feeds it the measurements of
:func:`fl_design.simulate` on the user's plant and scenario, started as firmware starts it, and
compares with ``Design.step`` in double on the same measurements: the relative error the
closed-loop SIL of the float package will measure (:mod:`fl_design.codegen._sil`), without a
compiler. :func:`fl_design.generate_c` calls it when given ``plant`` and ``scenario`` with
``precision="float"``, and warns (:class:`~fl_design.errors.FloatPrecisionWarning`) or
refuses (:class:`~fl_design.errors.PrecisionError`) above the bound, with the number and the
fixes.

Examples
--------
>>> import fl_design as fl
>>> from fl_design import presets
>>> from fl_design.codegen._float_check import predict_float_error
>>> p = fl.plants.maglev()
>>> err = predict_float_error(presets.maglev_design(), p, fl.Scenario(6.2e-3, 0.5))
>>> 0.0 < err < 1e-4
True
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..design import EHGO
from ._emit import MATH

_F = np.float32
_BIN = {ca.OP_ADD: lambda a, b: _F(a + b), ca.OP_SUB: lambda a, b: _F(a - b),
        ca.OP_MUL: lambda a, b: _F(a * b), ca.OP_DIV: lambda a, b: _F(a / b),
        ca.OP_FMIN: lambda a, b: min(b, a), ca.OP_FMAX: lambda a, b: max(b, a),
        ca.OP_LT: lambda a, b: _F(a < b), ca.OP_LE: lambda a, b: _F(a <= b),
        ca.OP_EQ: lambda a, b: _F(a == b), ca.OP_NE: lambda a, b: _F(a != b),
        ca.OP_AND: lambda a, b: _F(bool(a) and bool(b)),
        ca.OP_OR: lambda a, b: _F(bool(a) or bool(b)),
        ca.OP_IF_ELSE_ZERO: lambda c, x: x if c else _F(0)}
_UN = {ca.OP_NEG: lambda a: _F(-a), ca.OP_SQ: lambda a: _F(a * a),
       ca.OP_TWICE: lambda a: _F(a + a), ca.OP_ASSIGN: lambda a: a,
       ca.OP_NOT: lambda a: _F(not a), ca.OP_FABS: lambda a: _F(abs(a)),
       ca.OP_INV: lambda a: _F(_F(1) / a)}


def _program(f: ca.Function):
    prog = []
    for k in range(f.n_instructions()):
        op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op in MATH:
            raise NotImplementedError(f"{f.name()} uses a math function: not emulated")
        const = _F(f.instruction_constant(k)) if op == ca.OP_CONST else None
        prog.append((op, tuple(ins), tuple(outs), const))
    return prog


def emulate(design, ym, r, state0, *, y_c: float = 0.0) -> np.ndarray:
    """The float C step's inputs ``u`` for ``ym, r`` from ``state0`` (every operation in float32).

    Parameters
    ----------
    design : Design
        The design generated (:func:`~fl_design.codegen.step_design`).
    ym, r : array_like
        ``(N,)`` measurements and references (rounded to float, as the C API takes them).
    state0 : array_like
        Start state (rounded to float), in the C's deviation coordinates: relative to ``y_c``.
    y_c : float, optional
        The level the C state is measured from (``PREFIX_start`` sets it to ``y0``, the state
        then being ``Design.initial_state(y0=0)``; ``PREFIX_init``: 0). The step sees
        ``y - y_c`` and ``r - y_c``, rounded in float as the C computes them.

    Returns
    -------
    numpy.ndarray
        ``(N,)`` float32 values.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design import presets
    >>> from fl_design.codegen import step_design
    >>> from fl_design.codegen._float_check import emulate
    >>> d = step_design(presets.paper_design(), "float")
    >>> u = emulate(d, np.full(3, 0.1), np.full(3, 0.3), d.initial_state(y0=0.0), y_c=0.1)
    >>> u.dtype, bool(abs(u[-1] - d.run(np.full(3, 0.1), 0.3,
    ...                                  state0=d.initial_state(y0=0.1)).u[-1]) < 1e-6)
    (dtype('float32'), True)
    """
    from ._graph import parameter_fields, parametric_core

    f = parametric_core(design)
    prog = _program(f)
    p = np.array([fl.value for fl in parameter_fields(design)], dtype=_F)
    x = np.asarray(state0, dtype=_F).copy()
    w = [_F(0)] * max(int(f.sz_w()), 1)
    c = _F(y_c)
    ym, r = np.asarray(ym, dtype=_F) - c, np.asarray(r, dtype=_F) - c
    out = np.empty(ym.size, dtype=_F)
    for k in range(ym.size):
        inputs = (x, (ym[k],), (r[k],), p)
        x_next = np.empty_like(x)
        u = _F(0)
        for op, ins, outs, const in prog:
            if op == ca.OP_INPUT:
                w[outs[0]] = inputs[ins[0]][ins[1]]
            elif op == ca.OP_OUTPUT:
                if outs[0] == 0:
                    x_next[outs[1]] = w[ins[0]]
                elif outs[0] == 1:
                    u = w[ins[0]]
            elif op == ca.OP_CONST:
                w[outs[0]] = const
            elif op in _BIN:
                w[outs[0]] = _BIN[op](w[ins[0]], w[ins[1]])
            else:
                w[outs[0]] = _UN[op](w[ins[0]])
        x, out[k] = x_next, u
    return out


def predict_float_error(design, plant, scenario, *, max_samples: int = 10_000) -> float:
    """Predicted ``max |u_float - u_double| / max |u_double|`` of the float package's SIL.

    Parameters
    ----------
    design : Design
        The user's design.
    plant : Plant
        The plant.
    scenario : Scenario
        Reference, duration, noise (the run of :func:`fl_design.simulate`).
    max_samples : int, optional
        The first samples used (default 10 000).

    Returns
    -------
    float

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen._float_check import predict_float_error
    >>> predict_float_error(presets.paper_design(), fl.plants.trms_yaw(),
    ...                     fl.Scenario(0.3, 0.2)) < 1e-4
    True
    """
    return _total(_float_run(design, plant, scenario, max_samples))


def _total(run) -> float:
    """:func:`predict_float_error` of a :func:`_float_run`."""
    u64, u32 = run[4], run[5]
    return float(np.max(np.abs(u32 - u64)) / max(np.max(np.abs(u64)), np.finfo(float).tiny))


def _float_run(design, plant, scenario, max_samples: int):
    """``(used, ym, r, u0, u64, u32)``: the recorded run's measurements, ``Design.step`` on
    them in double and the emulated float step, started as the C starts."""
    from ._compare import recorded_run, reference_inputs
    from ._step import step_design

    used = step_design(design, "float")
    ym, r, u0 = recorded_run(plant, design, scenario, max_samples=max_samples)
    u64 = reference_inputs(used, ym, r, u0)
    start = used.initial_state(y0=0.0, u0=u0)  # the C start: deviations from y_c = ym[0]
    u32 = emulate(used, ym, r, np.asarray(start, dtype=_F), y_c=float(ym[0])).astype(float)
    return used, ym, r, u0, u64, u32


def float_error_budget(design, plant, scenario, *, max_samples: int = 10_000) -> dict:
    """:func:`predict_float_error` split: the step's own arithmetic and the measurement's rounding.

    The float C receives ``y`` and ``r`` as floats: rounded to 24 bits before the step
    runs, a noise of ``|y| 2^-25`` that the observer amplifies (``~1 / eps^rho``) as it
    amplifies any measurement noise. ``"arithmetic"`` compares the emulated float step with
    ``Design.step`` fed the same float measurements; ``"measurement"`` compares
    ``Design.step`` fed the float measurements with ``Design.step`` fed the recorded ones;
    ``"total"`` is :func:`predict_float_error` (at most their sum). Each is a fraction of
    ``max |u|`` of ``Design.step`` on the recorded measurements.

    Parameters
    ----------
    design, plant, scenario, max_samples
        As in :func:`predict_float_error`.

    Returns
    -------
    dict
        ``{"total": float, "arithmetic": float, "measurement": float}``.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen._float_check import float_error_budget
    >>> b = float_error_budget(presets.paper_design(), fl.plants.trms_yaw(),
    ...                        fl.Scenario(0.3, 0.2))
    >>> b["total"] <= b["arithmetic"] + b["measurement"] + 1e-12
    True
    """
    return _budget(_float_run(design, plant, scenario, max_samples))


def _budget(run) -> dict:
    """:func:`float_error_budget` of a :func:`_float_run` (one run serves the total and
    its split)."""
    from ._compare import reference_inputs

    used, ym, r, u0, u64, u32 = run
    y32, r32 = (np.asarray(v, dtype=_F).astype(float) for v in (ym, r))
    u64f = reference_inputs(used, y32, r32, u0)
    scale = max(float(np.max(np.abs(u64))), np.finfo(float).tiny)
    err = lambda a, b: float(np.max(np.abs(a - b)) / scale)
    return {"total": err(u32, u64), "arithmetic": err(u32, u64f),
            "measurement": err(u64f, u64)}


def fixes(design) -> str:
    """What to do when the float build misses its bound (for the messages).

    Parameters
    ----------
    design : Design
        The design whose float build missed (an EHGO also gets the advice on ``eps``).

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._float_check import fixes
    >>> "precision='double'" in fixes(presets.paper_design())
    True
    """
    text = "use precision='double' (a double FPU, or software double at ~20x the cost)"
    est = design.estimator
    if isinstance(est, EHGO):
        text += (f", or a larger eps (alpha = T/eps = {design.T / est.eps:.3g}; the float "
                 "rounding of y reaches sigmahat amplified by ~1/eps^rho)")
    return text + ", or a smaller gamma (u accumulates gamma (v - sigmahat) each sample)"


__all__ = ["emulate", "fixes", "float_error_budget", "predict_float_error"]
