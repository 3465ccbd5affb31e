"""The Q31 program as C statements and as a bit-exact Python model.

Each instruction of :class:`~fl_design.codegen._q31.Q31Program` becomes one ``int32_t`` (or
``bool``) constant: sums aligned in ``int64_t`` (at most 31 bits apart, so each operand is
below ``2^62``), products of two ``int32_t`` in ``int64_t``, results shifted to their fraction
bits (floor: the arithmetic right shift, written on the unsigned pattern in C). The Python
model applies the same integer operations to Python integers, so C and model agree bit for bit.

Where an identity of integer floors makes it exact, an instruction is printed in ``int32_t``
instead (no 64-bit pair: on an ARMv6-M/ARMv7-M core half the registers and instructions):
every value of the program lies within ``2^30`` (its fraction bits are chosen so: one bit of
headroom), so the sum ``w + floor(x / 2^k)`` of two of them, when it *is* the result, cannot
overflow. ``floor((w 2^k + x) / 2^k) = w + floor(x / 2^k)``, ``floor((w 2^k - x) / 2^k) =
w + floor(-x / 2^k)``, ``floor((x - w 2^k) / 2^k) = floor(x / 2^k) - w`` (a sum whose operand
of fewer fraction bits has the result's); ``floor(max(w 2^k, x) / 2^k) = max(w, floor(x /
2^k))`` (floor is monotone); a product by a constant ``+-2^m`` is a shift; ``2 w`` and ``-w``
likewise. A sum with a term scaled up is computed modulo ``2^32`` (``uint32_t``): the scaled
term is exact modulo ``2^32``, the other floored (``floor((A 2^p + B) / 2^q) = A 2^(p-q) +
floor(B / 2^q)``), and the result, within its interval, fits; a sum of two terms both scaled
down floors the finer first (:func:`_nested`); a difference is the sum with the negated value,
so each is the exact floor of the aligned sum (:func:`_sum32`). A product by a constant
``("mulc", c_q, 32)`` is ``floor(v c_q / 2^32)``, the high word (:func:`._q31._high_word`).

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen._q31 import q31_program
>>> from fl_design.codegen._q31_code import c_body_q31
>>> "_mulhi(" in c_body_q31(q31_program(presets.paper_design(), (-1.0, 1.0)))
True
"""

from __future__ import annotations

import re

import casadi as ca
import numpy as np

from ..errors import ComputationError
from ._q31 import _CMP, Q31Program


def _shift(v: str, f_from: int, f_to: int) -> str:
    s = f_from - f_to
    if s > 0:
        return f"{{PFX}}_asr({v}, {min(s, 63)}u)"
    if s < 0:
        return f"({v} * INT64_C({1 << -s}))"
    return v


def _py_shift(v: int, f_from: int, f_to: int) -> int:
    s = f_from - f_to
    return v >> min(s, 63) if s > 0 else v * (1 << -s) if s < 0 else v


def _align(fa: int, fb: int) -> int:
    return min(max(fa, fb), min(fa, fb) + 31)


def _shift32(v: str, s: int) -> str:
    """``v 2^-s`` of an ``int32_t`` expression whose result fits (floor for s > 0)."""
    if s >= 32:  # |v| < 2^31: floor(v / 2^s) is -1 or 0
        return f"(({v} < 0) ? INT32_C(-1) : INT32_C(0))"
    if s > 0:  # the multiplier 2^(32 - s) as a literal (see the template's _asr32)
        return f"{{PFX}}_asr32({v}, INT64_C({1 << (32 - s)}))"
    return f"({v} * INT32_C({1 << -s}))" if s < 0 else v


#: the template's saturating scale-up in 32 bits (written into the C only where a store uses it)
SAT_SHL = """/* q 2^k (1 <= k <= 30) saturated to int32_t, compared in 32 bits: q 2^k fits exactly when
 * -2^(31-k) <= q <= 2^(31-k) - 1 */
static int32_t {PFX}_sat_shl(int32_t q, uint32_t k) {
  const uint32_t top_bits = 0x7FFFFFFFu >> k;
  const uint32_t scale_bits = 1u << k;
  const int32_t top = (int32_t) top_bits;
  const int32_t scale = (int32_t) scale_bits;
  int32_t out;
  if (q > top) {
    out = (int32_t) INT32_MAX;
  } else if (q < (-top - 1)) {
    out = (int32_t) INT32_MIN;
  } else {
    out = q * scale;
  }
  return out;
}

"""


def _product(x: str, y: str, s: int) -> str:
    """``floor(x y / 2^s)`` of two ``int32_t`` as ``int32_t`` (it fits: the interval analysis):
    the template's ``_mulsh`` for ``1 <= s <= 63``, else the long product scaled up."""
    if 1 <= s <= 63:
        return f"{{PFX}}_mulsh({x}, {y}, {s}u)"
    return f"(int32_t) {_shift(f'{{PFX}}_mul({x}, {y})', s, 0)}"


def _sum32(op, a, F, name, fk):
    """The ``int32_t`` C of a sum or difference whose 32-bit form is exact (:func:`_nested`,
    :func:`_wraps`), else None. A difference is the sum with the negated value (``|v| <=
    2^30``: exact), so that each identity of floors is that of a sum."""
    terms = (name[a[0]], name[a[1]] if op == ca.OP_ADD else f"(-{name[a[1]]})")
    fs = (F[a[0]], F[a[1]])
    if _nested(*fs, fk):  # the finer term floored first
        lo = min(fs)
        inner = " + ".join(_shift32(t, f - lo) for t, f in zip(terms, fs))
        return _shift32(f"({inner})", lo - fk)
    if _wraps(*fs, fk):  # modulo 2^32: the result fits
        x0, x1 = (_wrap_term(t, f - fk) for t, f in zip(terms, fs))
        return f"{{PFX}}_s32({x0} + {x1})"
    return None


def _py_sum32(op, vals, fs, fk):
    """:func:`_sum32`'s value on Python integers (None where it gives no 32-bit form)."""
    terms = (vals[0], vals[1] if op == ca.OP_ADD else -vals[1])
    if _nested(*fs, fk):
        lo = min(fs)
        return _py_shift(sum(_py_shift(t, f, lo) for t, f in zip(terms, fs)), lo, fk)
    if _wraps(*fs, fk):
        return sum(_py_shift(t, f, fk) for t, f in zip(terms, fs))
    return None


def _nested(fa: int, fb: int, fk: int) -> bool:
    """A sum of two terms both scaled down, at different fraction bits ``F_lo < F_hi``, in
    32 bits: ``floor((A 2^p + B) / 2^s) = floor((A + floor(B / 2^p)) / 2^(s - p))`` (floor of
    a floor; an integer added inside a floor comes out), and ``|A + floor(B / 2^p)| <= 2^30 +
    2^29`` (each value within ``2^30`` at its own bits): no overflow, exact."""
    return fk < min(fa, fb) and fa != fb and abs(fa - fb) <= 31


def _wraps(fa: int, fb: int, fk: int) -> bool:
    """A sum printed in 32 bits modulo ``2^32``: one term scaled up (by at most ``2^30``),
    the other scaled down or not (``floor((A 2^p + B) / 2^q) = A 2^(p-q) + floor(B / 2^q)``
    when ``A 2^(p-q)`` is an integer: exact); both scaled down is not exact (``floor(a) +
    floor(-a) = -1``: a value at rest would creep) and stays a 64-bit sum."""
    lo, hi = min(fa, fb), max(fa, fb)
    return lo < fk <= hi + 30 and fk - lo <= 30


def _wrap_term(v: str, s: int) -> str:
    """A term of a sum in ``uint32_t`` at the result's fraction bits: ``floor(v / 2^s)`` for
    ``s >= 0``, ``v 2^-s`` modulo ``2^32`` for ``s < 0`` (the sum, which fits an ``int32_t``
    by the interval analysis, is then exact: two's complement arithmetic modulo ``2^32``)."""
    if s >= 0:
        return f"(uint32_t) {_shift32(v, s)}"
    return f"((uint32_t) {v} * {1 << -s}u)"


def _mul_const(x: str, cq: int, s: int) -> str:
    """``floor(x c_q / 2^s)``: the template's ``_mulhi`` (the high word) for ``s = 32``."""
    c = _const(cq, 0)
    if s == 32:
        return f"{{PFX}}_mulhi({x}, {c})"
    return _product(x, c, s)


def _narrow(op, a, F, name, fk, const):
    """The ``int32_t`` text of a sum, min/max, product by ``+-2^m``, twice or negation when an
    identity of floors makes it exact (module docstring), else None."""
    if op in (ca.OP_FMIN, ca.OP_FMAX):
        for z, v in ((a[0], a[1]), (a[1], a[0])):  # max(v, 0) = v > 0 ? v : 0, any scaling
            if const.get(z) == 0:
                cmp = ">" if op == ca.OP_FMAX else "<"
                return f"(({name[v]} {cmp} 0) ? {_shift32(name[v], F[v] - fk)} : INT32_C(0))"
        return _narrow_minmax(op, a, F, name, fk)
    if op in _SYM:
        (i, j), fm = a, _align(F[a[0]], F[a[1]])
        if fm != max(F[i], F[j]):
            return None  # operands more than 31 bits apart
        if F[i] == F[j] == fk:
            w, x, k = i, j, 0
        elif fk == min(F[i], F[j]) and F[i] != F[j]:
            (w, x), k = ((i, j) if F[i] < F[j] else (j, i)), fm - fk
        else:
            return None
        if op == ca.OP_ADD:
            return f"({name[w]} + {_shift32(name[x], k)})"
        if w == i:  # w 2^k - x
            return f"({name[w]} + {_shift32(f'(-{name[x]})', k)})"
        return f"({_shift32(name[x], k)} - {name[w]})"
    if op == ca.OP_MUL:
        for c, v in ((a[0], a[1]), (a[1], a[0])):
            m = const.get(c)
            if m is not None and m != 0 and (abs(m) & (abs(m) - 1)) == 0:
                e = abs(m).bit_length() - 1
                src = name[v] if m > 0 else f"(-{name[v]})"
                return _shift32(src, F[a[0]] + F[a[1]] - fk - e)
        return None
    if op == ca.OP_TWICE:
        return _shift32(name[a[0]], F[a[0]] - fk - 1)
    if op == ca.OP_NEG:
        return _shift32(f"(-{name[a[0]]})", F[a[0]] - fk)
    return None


def _narrow_minmax(op, a, F, name, fk):
    """``min``/``max`` in ``int32_t``: with ``A`` at ``F_A <= F_B``, ``floor(min(A 2^(F_B -
    F_A), B) / 2^s) = min(A 2^j, B')`` (``B' = floor(B / 2^(F_B - fk))``, ``j = fk - F_A``,
    floor is monotone), and ``A 2^j < B' <=> A <= floor((B' - 1) / 2^j)``, ``A 2^j > B' <=>
    A > floor(B' / 2^j)``: the comparison in 32 bits, ``A 2^j`` formed only when it is the
    result (which fits)."""
    (i, j), fm = a, _align(F[a[0]], F[a[1]])
    lo, hi = (i, j) if F[i] <= F[j] else (j, i)
    if fm != F[hi] or fk > F[hi]:
        return None  # operands more than 31 bits apart, or a result finer than both
    if fk <= F[lo]:
        xa, xb = _shift32(name[i], F[i] - fk), _shift32(name[j], F[j] - fk)
        return f"(({xa} {'<' if op == ca.OP_FMIN else '>'} {xb}) ? {xa} : {xb})"
    up, b = fk - F[lo], _shift32(name[hi], F[hi] - fk)
    cond = (f"{name[lo]} <= {_shift32(f'({b} - 1)', up)}" if op == ca.OP_FMIN
            else f"{name[lo]} > {_shift32(b, up)}")
    return f"(({cond}) ? ({name[lo]} * INT32_C({1 << up})) : {b})"


def _narrow_cmp(op, a, F, name):
    """``<`` / ``<=`` of two values in ``int32_t`` (``k = |F_A - F_B| <= 31``): ``A 2^k < B
    <=> A <= floor((B - 1) / 2^k)``, ``A 2^k <= B <=> A <= floor(B / 2^k)``, ``A < B 2^k <=>
    floor(A / 2^k) < B``, ``A <= B 2^k <=> floor((A - 1) / 2^k) < B`` (every value lies within
    ``2^30``: ``B - 1`` does not overflow); None for ``==``, ``!=``."""
    (i, j), fm = a, _align(F[a[0]], F[a[1]])
    if op not in (ca.OP_LT, ca.OP_LE) or fm != max(F[i], F[j]):
        return None
    if F[i] == F[j]:
        return f"({name[i]} {_CMP[op]} {name[j]})"
    if F[i] < F[j]:
        k = F[j] - F[i]
        b = f"({name[j]} - 1)" if op == ca.OP_LT else name[j]
        return f"({name[i]} <= {_shift32(b, k)})"
    k = F[i] - F[j]
    x = name[i] if op == ca.OP_LT else f"({name[i]} - 1)"
    return f"({_shift32(x, k)} < {name[j]})"


_SYM = {ca.OP_ADD: "+", ca.OP_SUB: "-"}


def c_body_q31(prog: Q31Program) -> str:
    """The statements of the Q31 core (``x, y, r -> x_next, u``; int32 in, int32 out).

    Parameters
    ----------
    prog : Q31Program
        The program.

    Returns
    -------
    str
        C statements (one per line), to be placed in the step's body by the template.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._q31 import q31_program
    >>> from fl_design.codegen._q31_code import c_body_q31
    >>> body = c_body_q31(q31_program(presets.paper_design(), (-1.0, 1.0)))
    >>> "float" in body or "double" in body, "int64_t" in body
    (False, True)
    """
    F, lines, name, const = {}, [], {}, {}
    for kind, k, a, fk, data in prog.ops:
        if kind == "in":
            F[k] = fk
            name[k] = f"x[{a[1]}]" if a[0] == 0 else ("y" if a[0] == 1 else "r")
            continue
        if kind == "out":
            (which, i), (w,) = k, a
            dst = f"x_next[{i}]" if which == 0 else "*u"
            if 1 <= fk - F[w] <= 30:  # scaled up: saturated in 32 bits (no int64_t)
                lines.append(f"  {dst} = {{PFX}}_sat_shl({name[w]}, {fk - F[w]}u);")
            else:
                lines.append(f"  {dst} = {{PFX}}_sat32({_shift(f'(int64_t) {name[w]}', F[w], fk)});")
            continue
        F[k], name[k] = fk, f"q{k}"
        q = lambda j: f"(int64_t) {name[j]}"
        op = data
        if op == "select":  # c ? x : y, each at the result's fraction bits (it fits)
            c, x, y = a
            lines.append(f"  const int32_t q{k} = ({name[c]} ? {_shift32(name[x], F[x] - fk)} : "
                         f"{_shift32(name[y], F[y] - fk)});")
            continue
        if isinstance(op, tuple):  # ("mulc", c_q, s): floor(v c_q / 2^s), the high word
            lines.append(f"  const int32_t q{k} = {_mul_const(name[a[0]], op[1], op[2])};")
            continue
        if not isinstance(op, int) or isinstance(op, bool):  # a constant
            lines.append(f"  const int32_t q{k} = {_const(data, fk)};")
            const[k] = round(data * 2.0**fk)
            continue
        if op in _SYM and (text := _sum32(op, a, F, name, fk)) is not None:
            lines.append(f"  const int32_t q{k} = {text};")
            continue
        narrow = _narrow(op, a, F, name, fk, const)
        if narrow is not None:
            lines.append(f"  const int32_t q{k} = {narrow};")
            continue
        if op in _SYM:
            fm = _align(F[a[0]], F[a[1]])
            expr = f"({_shift(q(a[0]), F[a[0]], fm)} {_SYM[op]} {_shift(q(a[1]), F[a[1]], fm)})"
            text = f"(int32_t) {_shift(expr, fm, fk)}"
        elif op == ca.OP_MUL:
            text = _product(name[a[0]], name[a[1]], F[a[0]] + F[a[1]] - fk)
        elif op == ca.OP_SQ:
            text = _product(name[a[0]], name[a[0]], 2 * F[a[0]] - fk)
        elif op == ca.OP_NEG:
            text = f"(int32_t) {_shift(f'(-{q(a[0])})', F[a[0]], fk)}"
        elif op == ca.OP_TWICE:
            text = f"(int32_t) {_shift(f'({q(a[0])} * 2)', F[a[0]], fk)}"
        elif op == ca.OP_ASSIGN:
            text = name[a[0]]
        elif op in (ca.OP_FMIN, ca.OP_FMAX):
            fm = _align(F[a[0]], F[a[1]])
            A, B = _shift(q(a[0]), F[a[0]], fm), _shift(q(a[1]), F[a[1]], fm)
            cmp = "<" if op == ca.OP_FMIN else ">"
            text = f"(int32_t) {_shift(f'(({A} {cmp} {B}) ? {A} : {B})', fm, fk)}"
        elif op in _CMP and (cmp := _narrow_cmp(op, a, F, name)) is not None:
            lines.append(f"  const bool q{k} = {cmp};")
            continue
        elif op in _CMP:
            fm = _align(F[a[0]], F[a[1]])
            A, B = _shift(q(a[0]), F[a[0]], fm), _shift(q(a[1]), F[a[1]], fm)
            lines.append(f"  const bool q{k} = ({A} {_CMP[op]} {B});")
            continue
        elif op == ca.OP_NOT:
            lines.append(f"  const bool q{k} = !{name[a[0]]};")
            continue
        elif op in (ca.OP_AND, ca.OP_OR):
            sym = "&&" if op == ca.OP_AND else "||"
            lines.append(f"  const bool q{k} = ({name[a[0]]} {sym} {name[a[1]]});")
            continue
        elif op == ca.OP_IF_ELSE_ZERO:
            text = f"({name[a[0]]} ? (int32_t) {_shift(q(a[1]), F[a[1]], fk)} : 0)"
        else:
            raise ComputationError(f"CasADi operation {op} has no Q31 translation")
        lines.append(f"  const int32_t q{k} = {text};")
    return "\n".join(_used(lines, const))


def _used(lines, const) -> list[str]:
    """The lines without the values no statement reads (a product by ``2^m`` became a shift,
    a select reads its two values, not their zero-padded terms): ``-Wunused-variable``."""
    del const
    while True:
        text = "\n".join(lines)
        dead = [ln for ln in lines if (m := re.match(r"  const (?:int32_t|bool) (q\d+) = ", ln))
                and len(re.findall(rf"\b{m.group(1)}\b", text)) == 1]
        if not dead:
            return lines
        lines = [ln for ln in lines if ln not in dead]


def _const(c: float, f: int) -> str:
    v = round(c * 2.0**f)
    return f"INT32_C({v})" if v >= 0 else f"(-INT32_C({-v}))"


def emulate_q31(prog: Q31Program, yq, rq, xq0) -> tuple[np.ndarray, np.ndarray]:
    """The Q31 C core on integer samples, bit for bit: ``(u_q, x_q)`` after each sample.

    Parameters
    ----------
    prog : Q31Program
        The program.
    yq, rq : sequence of int
        Measurements and references in Q format (``f_y`` fraction bits).
    xq0 : sequence of int
        Start state (``f_state`` fraction bits).

    Returns
    -------
    tuple of numpy.ndarray
        ``(N,)`` inputs and ``(N, n)`` states, integers.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._q31 import q31_program
    >>> from fl_design.codegen._q31_code import emulate_q31, start_state
    >>> prog = q31_program(presets.paper_design(), (-1.0, 1.0))
    >>> y0 = 1 << (prog.f_y - 3)
    >>> u, _ = emulate_q31(prog, [y0] * 3, [y0] * 3, start_state(prog, y0, 0))
    >>> u.tolist()
    [0, 0, 0]
    """
    x = [int(v) for v in xq0]
    us, xs = [], []
    for y, r in zip(yq, rq):
        w, xn, u = {}, [0] * prog.n_out, 0
        for kind, k, a, fk, data in prog.ops:
            if kind == "in":
                w[k] = x[a[1]] if a[0] == 0 else (int(y) if a[0] == 1 else int(r))
                continue
            if kind == "out":
                (which, i), (j,) = k, a
                v = _sat(_py_shift(w[j], _F_of(prog, j), fk))
                if which == 0:
                    xn[i] = v
                else:
                    u = v
                continue
            w[k] = _py_op(prog, w, k, a, fk, data)
        x = xn
        us.append(u)
        xs.append(list(x))
    return np.array(us, dtype=np.int64), np.array(xs, dtype=np.int64)


def _F_of(prog, j):
    return _fmap(prog)[j]


#: the fraction bits of the last program asked for (the program itself is kept: a cache keyed
#: by ``id`` alone returned a freed program's map to a new one at the same address)
_FCACHE: list = [None, None]


def _fmap(prog):
    if _FCACHE[0] is not prog:
        _FCACHE[:] = [prog, {k: fk for kind, k, a, fk, data in prog.ops if kind != "out"}]
    return _FCACHE[1]


def _sat(v: int) -> int:
    return max(-(2**31), min(2**31 - 1, v))


def _py_op(prog, w, k, a, fk, op):
    F = _fmap(prog)
    if op == "select":
        c, x, y = a
        return _py_shift(w[x], F[x], fk) if w[c] else _py_shift(w[y], F[y], fk)
    if isinstance(op, tuple):  # ("mulc", c_q, s)
        return (w[a[0]] * op[1]) >> op[2]
    if not isinstance(op, int) or isinstance(op, bool):
        return round(op * 2.0**fk)
    if op in _SYM and (v := _py_sum32(op, (w[a[0]], w[a[1]]), (F[a[0]], F[a[1]]), fk)) is not None:
        return v
    if op in _SYM:
        fm = _align(F[a[0]], F[a[1]])
        A, B = _py_shift(w[a[0]], F[a[0]], fm), _py_shift(w[a[1]], F[a[1]], fm)
        return _py_shift(A + B if op == ca.OP_ADD else A - B, fm, fk)
    if op == ca.OP_MUL:
        return _py_shift(w[a[0]] * w[a[1]], F[a[0]] + F[a[1]], fk)
    if op == ca.OP_SQ:
        return _py_shift(w[a[0]] * w[a[0]], 2 * F[a[0]], fk)
    if op == ca.OP_NEG:
        return _py_shift(-w[a[0]], F[a[0]], fk)
    if op == ca.OP_TWICE:
        return _py_shift(w[a[0]] * 2, F[a[0]], fk)
    if op == ca.OP_ASSIGN:
        return w[a[0]]
    if op in (ca.OP_FMIN, ca.OP_FMAX) or op in _CMP:
        fm = _align(F[a[0]], F[a[1]])
        A, B = _py_shift(w[a[0]], F[a[0]], fm), _py_shift(w[a[1]], F[a[1]], fm)
        if op == ca.OP_FMIN:
            return _py_shift(min(A, B), fm, fk)
        if op == ca.OP_FMAX:
            return _py_shift(max(A, B), fm, fk)
        return int({ca.OP_LT: A < B, ca.OP_LE: A <= B, ca.OP_EQ: A == B, ca.OP_NE: A != B}[op])
    if op == ca.OP_NOT:
        return int(not w[a[0]])
    if op == ca.OP_AND:
        return int(bool(w[a[0]]) and bool(w[a[1]]))
    if op == ca.OP_OR:
        return int(bool(w[a[0]]) or bool(w[a[1]]))
    if op == ca.OP_IF_ELSE_ZERO:
        return _py_shift(w[a[1]], F[a[1]], fk) if w[a[0]] else 0
    raise ComputationError(f"CasADi operation {op} has no Q31 translation")


def start_state(prog: Q31Program, y0q: int, u0q: int) -> list[int]:
    """The start state in Q format: the observer at rest at ``y0``, ``u = u0``, ``z = 0``
    (the C start's integer arithmetic).

    Parameters
    ----------
    prog : Q31Program
        The program.
    y0q, u0q : int
        ``y0`` (``f_y`` bits) and ``u0`` (``u``'s bits, clamped by the caller).

    Returns
    -------
    list of int

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._q31 import q31_program
    >>> from fl_design.codegen._q31_code import start_state
    >>> prog = q31_program(presets.paper_design(), (-1.0, 1.0))
    >>> start_state(prog, 1 << prog.f_y, 0)[0] == 1 << prog.f_state[0]
    True
    """
    m = prog.n_out - 2
    x = [_sat(prog.start0[i] + _py_shift(prog.start1[i] * int(y0q), prog.f_start1 + prog.f_y,
                                         prog.f_state[i])) for i in range(m)]
    return x + [int(u0q), 0]


def start_c(prog: Q31Program) -> str:
    """C statements of the start (``s->x[i]`` from ``y0``), matching :func:`start_state`."""
    m = prog.n_out - 2
    rows = []
    for i in range(m):
        prod = _shift(f"((int64_t) {prog.start1[i]} * (int64_t) y0)",
                      prog.f_start1 + prog.f_y, prog.f_state[i])
        rows.append(f"  s->x[{i}] = {{PFX}}_sat32((int64_t) {_const(prog.start0[i], 0)} + "
                    f"{prod});")
    return "\n".join(rows)


__all__ = ["SAT_SHL", "c_body_q31", "emulate_q31", "start_c", "start_state"]
