"""Fixed point for FPU-less chips: the step as Q31 integer code, its scalings from interval analysis.

``generate_c(..., precision="q31")`` prints ``Design.step`` (its numbers fixed: the gains,
``gamma`` and the limits are constants of a Q31 build) as integer code: every value is an
``int32_t`` holding ``v 2^F`` with its own number of fraction bits ``F``; products are formed in
``int64_t`` and shifted back (a product by a constant is the product's high word, the constant
scaled for it: :func:`_high_word`); no floating-point operation, type or helper anywhere.
The graph is the design's step with its EHGO's delta update as a recursion and the
controller's sums collapsed (:mod:`._q31_realize`) when that has fewer products.

**Scalings.** Each value's ``F`` comes from an interval that contains it on every sample
(one bit of headroom: ``|v| 2^F <= 2^30``):

- ``y`` and ``r``: the plausibility range ``[y_min, y_max]`` (the plant's region, see
  :mod:`fl_design.codegen._guard`); the wrapper rejects a ``y`` outside it and clamps ``r``;
- the observer's state: its rest point at the range's middle plus, per entry, the peak gain
  ``sum_j |(A^j B)_i|`` times the range's half-width (exact for a linear, Schur observer fed
  any input within the range, from any start at rest in it);
- ``u``: ``[u_min, u_max]`` (saturated); ``z``: ``k_I |z| <= k_1 (y_max - y_min)``, the
  proportional term's full scale, so ``z`` saturates there (a stated difference from
  ``Design.step``, whose ``z`` is unbounded; with ``k_I = 0``, ``|z| <= 2^20 T``). Known
  limit: in 32 bits that range leaves ``z`` a resolution of ``2^-F_z``, so increments
  ``T |y - r|`` below it are lost (a dead band of the integral action near the reference;
  a 64-bit ``z`` is the fix, not done);
- every intermediate value: interval arithmetic over the graph from these boxes, and for a
  value affine in the observer's state and ``y`` its peak-gain bound where tighter
  (:mod:`._q31_peak`: the sums of large estimates that cancel).

**No overflow.** Each ``int32_t`` result lies within its interval, hence within
``+-2^30 / 2^F``; the ``int64_t`` intermediates are sums of two values below ``2^62`` and
products of two ``int32_t``; a sum computed modulo ``2^32`` has its result within its
interval (:mod:`._q31_code`). The state's entries are stored through a saturation that the
bounds above never reach (interval arithmetic of one step is looser than the peak-gain bound).

**Error.** :func:`fl_design.codegen._q31_code.emulate_q31` runs the same integer program in
Python, bit for bit; its inputs
against ``Design.step``'s measure the quantization error (``CPackage`` records it as
``predicted_float_error`` for this precision).

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen._q31 import q31_program
>>> prog = q31_program(presets.paper_design(), (-10.0, 10.0))
>>> prog.f_y, prog.f_state[-2]   # fraction bits of y and of u
(26, 28)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import ComputationError, ParameterError
from ._emit import _select
from ._q31_peak import PeakGain, affine_step, split_form
from ._q31_realize import Realization, delta_realization
from ._q31_realize import fixed_core as _fixed_core
from ._q31_realize import linear_maps as _linear_maps

_LIMIT = 2.0**30  # one bit of headroom below 2^31
_F_MAX = 60


def frac_bits(lo: float, hi: float) -> int:
    """Fraction bits ``F`` with ``max(|lo|, |hi|) 2^F <= 2^30`` (at most 60).

    Parameters
    ----------
    lo, hi : float
        An interval.

    Returns
    -------
    int

    Examples
    --------
    >>> from fl_design.codegen._q31 import frac_bits
    >>> frac_bits(-1.0, 1.0), frac_bits(0.0, 24.0), frac_bits(0.0, 0.0)
    (30, 25, 60)
    """
    m = max(abs(lo), abs(hi))
    if not math.isfinite(m):
        raise ComputationError(f"an interval [{lo}, {hi}] of the Q31 step is not finite")
    if m == 0.0:
        return _F_MAX
    return int(min(_F_MAX, math.floor(math.log2(_LIMIT / m))))


@dataclass(frozen=True)
class Q31Program:
    """The integer program of one step: its instructions, C text and scalings.

    Parameters
    ----------
    ops : tuple
        ``(kind, out, args, F_out, data)`` per instruction (see :func:`q31_program`).
    f_state : tuple of int
        Fraction bits of each state entry (estimator | u | z).
    f_y : int
        Fraction bits of ``y`` and ``r``.
    state_box : tuple of (float, float)
        The interval of each state entry.
    y_range : (float, float)
        The range of ``y`` and ``r``.
    n_out : int
        State size (``x_next`` entries before ``u``).
    start0, start1 : tuple of int
        The start's rest state ``(start0 + start1 * y0) >> ...`` in fixed point (see C).
    f_start1 : int
        Fraction bits of ``start1``.
    realization : str
        How the observer's update is computed: ``"recursion"`` (the EHGO's delta update as
        its recursion, :mod:`._q31_realize`) or ``"direct"`` (its matrix).

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._q31 import q31_program
    >>> len(q31_program(presets.paper_design(), (-1.0, 1.0)).ops) > 50
    True
    """

    ops: tuple
    f_state: tuple
    f_y: int
    state_box: tuple
    y_range: tuple
    n_out: int
    start0: tuple
    start1: tuple
    f_start1: int
    realization: str = "direct"


def _peak_gain(A, B, n_max: int = 2_000_000) -> np.ndarray:
    """``sum_j |A^j B|`` per entry (until the terms are below 1e-15 of the sum)."""
    if np.max(np.abs(np.linalg.eigvals(A))) >= 1.0:
        raise ComputationError("the observer is not Schur: no bounded state for Q31")
    total, v = np.zeros_like(B), B.copy()
    for _ in range(n_max):
        total += np.abs(v)
        v = A @ v
        if np.max(np.abs(v)) <= 1e-15 * max(np.max(total), 1e-300):
            return total
    raise ComputationError("the observer's peak gain did not converge (a pole at 1?)")


def state_box(design, y_range, realization=None):
    """The interval of each state entry (module docstring) and ``(c0, c1)`` of the rest state.

    Parameters
    ----------
    design : Design
        The generated design (delta realization).
    y_range : (float, float)
        Range of ``y`` and ``r``.
    realization : Realization, optional
        The observer's update (:mod:`._q31_realize`; default the estimator's).

    Returns
    -------
    tuple
        ``(boxes, c0, c1)``.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import step_design
    >>> from fl_design.codegen._q31 import state_box
    >>> boxes, c0, c1 = state_box(step_design(presets.paper_design(), "q31"), (-1.0, 1.0))
    >>> boxes[-2]
    (-2.5, 2.5)
    """
    from ._graph import start_map

    lo, hi = y_range
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    if realization is None:
        A, B = _linear_maps(design)
        c0, c1 = start_map(design)
    else:
        A, B = realization.A, realization.B
        c0, c1 = start_map(design)
    gain = _peak_gain(A, B) * half
    rest = c0 + c1 * mid
    boxes = [(float(a - g), float(a + g)) for a, g in zip(rest, gain)]
    ctrl = design.controller
    if ctrl.u_range is None:
        raise ParameterError("precision='q31' needs u_limits on the controller (the input's "
                             "fixed-point range): give DynamicController(..., u_limits=...)")
    boxes.append(tuple(float(v) for v in ctrl.u_range))
    boxes.append((0.0, 0.0))  # z: set after the first pass (needs v's other terms)
    return boxes, c0, c1


_CMP = {ca.OP_LT: "<", ca.OP_LE: "<=", ca.OP_EQ: "==", ca.OP_NE: "!="}


def _analyse(f, boxes, y_range, peak=None):
    """Intervals of every instruction of ``f`` (x, y, r) from the input boxes; a select
    (:func:`._emit._select`) has the hull of its two values' intervals (it is one of them).
    With ``peak`` (:class:`._q31_peak.PeakGain`) a value affine in the inputs also has its peak-gain
    bound, and the tighter of the two holds."""
    iv, kind, node = {}, {}, {}
    cur, forms, const = {}, {}, {}
    for k in range(f.n_instructions()):
        op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op == ca.OP_OUTPUT:
            continue
        if op == ca.OP_INPUT:
            box = boxes[ins[1]] if ins[0] == 0 else y_range
            iv[k], kind[k] = box, "q"
            forms[k] = ({ins[1] if ins[0] == 0 else ("y" if ins[0] == 1 else "r"): 1.0}, 0.0)
            cur[outs[0]] = k
            continue
        a = [cur[i] for i in ins if i >= 0] if op != ca.OP_CONST else []
        if op == ca.OP_CONST:
            c = f.instruction_constant(k)
            iv[k], kind[k] = (c, c), "q"
            forms[k], const[k] = ({}, c), c
        elif op == ca.OP_ADD and _select(node, *a):
            _, x, y = _select(node, *a)
            iv[k] = (min(iv[x][0], iv[y][0]), max(iv[x][1], iv[y][1]))
            kind[k] = "q"
        elif op in (ca.OP_ADD, ca.OP_SUB, ca.OP_MUL, ca.OP_FMIN, ca.OP_FMAX):
            (l1, h1), (l2, h2) = iv[a[0]], iv[a[1]]
            if op == ca.OP_ADD:
                iv[k] = (l1 + l2, h1 + h2)
            elif op == ca.OP_SUB:
                iv[k] = (l1 - h2, h1 - l2)
            elif op == ca.OP_MUL:
                p = (l1 * l2, l1 * h2, h1 * l2, h1 * h2)
                iv[k] = (min(p), max(p))
            elif op == ca.OP_FMIN:
                iv[k] = (min(l1, l2), min(h1, h2))
            else:
                iv[k] = (max(l1, l2), max(h1, h2))
            kind[k] = "q"
        elif op == ca.OP_NEG:
            iv[k], kind[k] = (-iv[a[0]][1], -iv[a[0]][0]), "q"
        elif op == ca.OP_TWICE:
            iv[k], kind[k] = (2 * iv[a[0]][0], 2 * iv[a[0]][1]), "q"
        elif op == ca.OP_SQ:
            lo, hi = iv[a[0]]
            iv[k] = (0.0 if lo <= 0 <= hi else min(lo * lo, hi * hi), max(lo * lo, hi * hi))
            kind[k] = "q"
        elif op == ca.OP_ASSIGN:
            iv[k], kind[k] = iv[a[0]], kind[a[0]]
        elif op == ca.OP_IF_ELSE_ZERO:
            lo, hi = iv[a[1]]
            iv[k], kind[k] = (min(lo, 0.0), max(hi, 0.0)), "q"
            node[k] = ("ifz", a[0], a[1])
        elif op in _CMP or op in (ca.OP_NOT, ca.OP_AND, ca.OP_OR):
            iv[k], kind[k] = (0.0, 1.0), "b"
            if op == ca.OP_NOT:
                node[k] = ("not", a[0])
        else:
            raise ComputationError(f"CasADi operation {op} has no Q31 translation (the "
                                   "library's estimators use +, -, *, min, max, compare)")
        if op != ca.OP_CONST and kind[k] == "q" and (fk := affine_step(op, a, forms, const)):
            forms[k] = fk
            if peak is not None:
                own, other = split_form(fk, peak.m)
                lo, hi = peak.bound(own)
                for i, v in other.items():  # r, u, z: their boxes
                    b = boxes[i] if i != "r" else y_range
                    lo, hi = lo + min(v * b[0], v * b[1]), hi + max(v * b[0], v * b[1])
                iv[k] = (max(iv[k][0], lo), min(iv[k][1], hi))
        cur[outs[0]] = k
    return iv, kind


def _high_word(a, consts, F, f_max):
    """A product by a constant ``c`` (not 0, not ``+-2^m``: a shift) as the high word of the
    32 x 32 -> 64-bit product, ``floor(v c_q / 2^32)``: ``c_q = round(c 2^F_c)`` with ``F_c``
    chosen so that the result has ``F_v + F_c - 32`` fraction bits, at most ``f_max`` (the
    interval's) and ``|c_q| < 2^31``; one ``SMULL`` on an ARMv7-M core (no low word, no
    shift); on an ARMv6-M one the four 16 x 16 products' carries into the high word only (no
    low word, no 64-bit shift). The result has at most three bits fewer than ``f_max`` (never
    more: no overflow); the rounding is ``floor``, as everywhere, and the integer model
    (:func:`._q31_code.emulate_q31`) computes the same word. Returns ``((v,), F_out, ("mulc",
    c_q, 32))`` or None (then the full product)."""
    for c, v in ((a[0], a[1]), (a[1], a[0])):
        if c not in consts or v in consts:
            continue
        m = consts[c]
        if m == 0.0 or math.frexp(abs(m))[0] == 0.5:
            return None  # zero, or a power of two (a shift)
        f_c_max = math.floor(math.log2((2.0**31 - 1.0) / abs(m)))
        while abs(round(m * 2.0**f_c_max)) > 2**31 - 1:
            f_c_max -= 1
        f_out = min(f_max, F[v] + f_c_max - 32)
        f_c = f_out + 32 - F[v]
        cq = round(m * 2.0**f_c)
        if cq == 0 or f_out < f_max - 3:
            return None  # the constant too coarse at this scaling: the long product
        return (v,), f_out, ("mulc", int(cq), 32)
    return None


def q31_program(design, y_range, update: str = "auto") -> Q31Program:
    """The step of ``design`` (after :func:`~fl_design.codegen.step_design`) as Q31 code.

    Parameters
    ----------
    design : Design
        EHGO or least-squares design with ``u_limits``.
    y_range : (float, float)
        Range of ``y`` and ``r``.
    update : {"auto", "matrix"}, optional
        The observer's update: as its recursion when that has fewer products
        (:mod:`._q31_realize`), or always as its matrix.

    Returns
    -------
    Q31Program

    Raises
    ------
    ParameterError
        No ``u_limits``; an empty ``y_range``.
    ComputationError
        An operation without a Q31 translation, or an unbounded interval.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._q31 import q31_program
    >>> q31_program(presets.maglev_design(), (0.002, 0.010)).f_y
    36
    """
    lo, hi = (float(v) for v in y_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ParameterError(f"y_range={y_range!r} must be a finite (lo, hi) with lo < hi")
    if update not in ("auto", "matrix"):
        raise ParameterError(f"update={update!r} is not known; valid: 'auto', 'matrix'")
    real = _cheapest(design, (lo, hi)) if update == "auto" else _matrix(design)
    f = real.core
    boxes, c0, c1 = state_box(design, (lo, hi), real)
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    peak = PeakGain(real.A, real.B, c0 + c1 * mid, mid, half)
    iv, _ = _analyse(f, boxes, (lo, hi), peak)
    # z's box: k_I |z| at most k_1 (y_max - y_min), the proportional term's full scale
    ctrl = design.controller
    zb = ctrl.gains[0] * (hi - lo) / ctrl.ki if ctrl.ki > 0 else 2.0**20 * design.T
    boxes[-1] = (-zb, zb)
    iv, kind = _analyse(f, boxes, (lo, hi), peak)
    f_state = tuple(frac_bits(*b) for b in boxes)
    f_y = frac_bits(lo, hi)
    ops, F, cur, node, consts = [], {}, {}, {}, {}
    for k in range(f.n_instructions()):
        op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op == ca.OP_OUTPUT:
            w = cur[ins[0]]
            fo = f_state[outs[1]] if outs[0] == 0 else f_state[-2]
            ops.append(("out", (outs[0], outs[1]), (w,), fo, boxes[outs[1]] if outs[0] == 0
                        else boxes[-2]))
            continue
        if op == ca.OP_INPUT:
            F[k] = f_state[ins[1]] if ins[0] == 0 else f_y
            ops.append(("in", k, (ins[0], ins[1]), F[k], None))
            cur[outs[0]] = k
            continue
        a = tuple(cur[i] for i in ins if i >= 0) if op != ca.OP_CONST else ()
        if op == ca.OP_IF_ELSE_ZERO:
            node[k] = ("ifz", a[0], a[1])
        elif op == ca.OP_NOT:
            node[k] = ("not", a[0])
        elif op == ca.OP_ADD and _select(node, *a):
            a, op = _select(node, *a), "select"  # (c, x, y): c ? x : y
        if kind[k] == "b":
            F[k] = 0
        elif op == ca.OP_CONST:
            c = f.instruction_constant(k)
            F[k] = frac_bits(c, c)
        else:
            F[k] = frac_bits(*iv[k])
        data = f.instruction_constant(k) if op == ca.OP_CONST else op
        if op == ca.OP_CONST:
            consts[k] = data
        elif op == ca.OP_MUL and (mc := _high_word(a, consts, F, F[k])) is not None:
            a, F[k], data = mc
        ops.append(("op", k, a, F[k], data))
        cur[outs[0]] = k
    s0 = tuple(round(v * 2.0 ** f_state[i]) for i, v in enumerate(c0))
    f1 = min(frac_bits(*(float(np.min(c1)), float(np.max(c1)))), 30)
    s1 = tuple(round(v * 2.0**f1) for v in c1)
    return Q31Program(tuple(ops), f_state, f_y, tuple(boxes), (lo, hi), design.state_size,
                      s0, s1, f1, real.name)


def _products(f) -> int:
    """Products of ``f`` other than by ``0`` or ``+-2^m`` (shifts)."""
    const, n = {}, 0
    for k in range(f.n_instructions()):
        op = f.instruction_id(k)
        if op == ca.OP_CONST:
            const[f.instruction_output(k)[0]] = f.instruction_constant(k)
        elif op in (ca.OP_MUL, ca.OP_SQ):
            cs = [const.get(i) for i in f.instruction_input(k) if i >= 0]
            n += not any(c is not None and (c == 0.0 or math.frexp(abs(c))[0] == 0.5)
                         for c in cs)
    return n


def _cheapest(design, y_range):
    """The core with fewer products: the EHGO's delta update as its recursion
    (:mod:`._q31_realize`) when it applies and saves some, else the matrix form."""

    f0 = _fixed_core(design)
    real = delta_realization(design, y_range, f0)
    if real.name != "direct" and _products(real.core) < _products(f0):
        return real
    return _matrix(design, f0, real.why or "no fewer products")


def _matrix(design, f0=None, why: str = "asked for"):
    A, B = _linear_maps(design)
    return Realization("direct", _fixed_core(design) if f0 is None else f0, A, B, why)


__all__ = ["Q31Program", "frac_bits", "q31_program", "state_box"]
