"""Fewer products for the Q31 step: constants equal up to a power of two share one multiplication.

An observer's update ``g_i = sum_j G_ij e_j`` often has coefficients that differ by a power of
two only (the EHGO's ``G`` scaled by powers of ``eps`` when ``eps`` is one, a row of equal
gains); in Q31 each product is a 32 x 32 -> 64-bit multiplication (a library call on a
Cortex-M0+, which has no long multiply), while a product by a power of two is a shift.
:func:`factor_constants` rewrites every sum of products by constants (a chain of ``+``/``-``
whose inner sums are used once) as ``c (t_1 + 2^e2 t_2 + ...)`` per group of coefficients
``c, 2^e2 c, ...`` (the largest ``|c|`` kept, so the other terms are shifted right): the same
value in real arithmetic, fewer roundings. The Q31 program's interval analysis, scalings and
integer model (:mod:`._q31`) then take the rewritten graph as they take any other: the no
overflow proof and the measured quantization error are the rewritten step's own.

Examples
--------
>>> import casadi as ca
>>> from fl_design.codegen._q31_factor import factor_constants
>>> x = ca.SX.sym("x", 3)
>>> f = ca.Function("f", [x], [0.3 * x[0] + 0.15 * x[1] - 0.6 * x[2]])
>>> g = factor_constants(f)
>>> print(g(x))  # doctest: +SKIP
(-0.6*((x_2-(0.5*x_0))-(0.25*x_1)))
>>> consts = [g.instruction_constant(k) for k in range(g.n_instructions())
...           if g.instruction_id(k) == ca.OP_CONST]
>>> sorted(abs(c) for c in consts)  # one product by 0.6, two shifts
[0.25, 0.5, 0.6]
>>> abs(float(g([1.0, 2.0, 3.0])) - float(f([1.0, 2.0, 3.0]))) < 1e-15
True
"""

from __future__ import annotations

import math

import casadi as ca


def _key(c: float) -> float:
    """The coefficient up to sign and power of two (its mantissa)."""
    return math.frexp(abs(c))[0]


class _Rewriter:
    def __init__(self, f: ca.Function):
        self.f = f
        self.uses: dict[int, int] = {}
        self.orig: dict[int, ca.SX] = {}  # each value as the original operations print it
        self.terms_of: dict[int, list] = {}  # a sum of products: [(sign, const, SX)]
        self.done: dict[int, ca.SX] = {}

    def sx(self, k: int) -> ca.SX:
        """Value ``k`` as one expression: factored when two of its terms share a constant up
        to a power of two, else as the original operations print it (built once)."""
        if k not in self.done:
            terms = self.terms_of.get(k)
            self.done[k] = _sum(terms) if terms and _shared(terms) else self.orig[k]
        return self.done[k]

    def terms(self, k: int) -> list:
        """Value ``k`` as terms: its own when used once (flattened into its user)."""
        if k in self.terms_of and self.uses.get(k, 0) == 1:
            return self.terms_of[k]
        return [(1.0, None, self.sx(k))]


def _key(c) -> float:
    """A coefficient up to sign and power of two (its mantissa); None for a plain term."""
    return None if c is None else math.frexp(abs(c))[0]


def _shared(terms) -> bool:
    keys = [_key(c) for _, c, _ in terms if c is not None]
    return len(keys) != len(set(keys))


def _sum(terms) -> ca.SX:
    """``sum s_j c_j t_j``, the terms whose constants are equal up to a power of two sharing
    one product (by the largest), the others as they were (``+ c t`` or ``- c t``)."""
    groups: dict = {}
    for i, (sign, c, t) in enumerate(terms):
        groups.setdefault(("plain", i) if c is None else _key(c), []).append((sign, c, t))
    total = None
    for group in groups.values():
        if len(group) == 1:
            sign, c, t = group[0]
            part = t if c is None else ca.SX(c) * t
        else:
            c0 = max((c for _, c, _ in group), key=abs)
            inner = None
            for s, c, t in group:
                ratio = s * c / c0  # +-2^e, exact
                term = t if ratio == 1.0 else -t if ratio == -1.0 else ca.SX(ratio) * t
                inner = term if inner is None else inner + term
            part, sign = ca.SX(c0) * inner, 1.0
        if total is None:
            total = part if sign > 0 else -part
        else:
            total = total + part if sign > 0 else total - part
    return total


def factor_constants(f: ca.Function) -> ca.Function:
    """``f`` with its sums of products by constants factored (see the module docstring).

    Parameters
    ----------
    f : casadi.Function
        An SX function.

    Returns
    -------
    casadi.Function
        Same inputs and outputs, the same values in real arithmetic.

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.codegen._q31_factor import factor_constants
    >>> x = ca.SX.sym("x", 2)
    >>> g = factor_constants(ca.Function("f", [x], [0.5 * x[0] + 0.25 * x[1]]))
    >>> float(g([2.0, 4.0]))
    2.0
    """
    rw = _Rewriter(f)
    cur = {}
    n = f.n_instructions()
    for k in range(n):
        op, ins = f.instruction_id(k), f.instruction_input(k)
        if op not in (ca.OP_INPUT, ca.OP_CONST):
            for i in ins:
                if i >= 0:
                    rw.uses[cur[i]] = rw.uses.get(cur[i], 0) + 1
        if op != ca.OP_OUTPUT:
            cur[f.instruction_output(k)[0]] = k
    args = [ca.SX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())]
    outs = [[None] * f.nnz_out(i) for i in range(f.n_out())]
    const, cur = {}, {}
    for k in range(n):
        op, ins, out = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op == ca.OP_OUTPUT:
            outs[out[0]][out[1]] = rw.sx(cur[ins[0]])
            continue
        a = [cur[i] for i in ins if i >= 0] if op not in (ca.OP_INPUT, ca.OP_CONST) else []
        if op == ca.OP_INPUT:
            rw.orig[k] = args[ins[0]].nz[ins[1]]
        elif op == ca.OP_CONST:
            const[k] = f.instruction_constant(k)
            rw.orig[k] = ca.SX(const[k])
        elif len(a) == 2:
            rw.orig[k] = ca.SX.binary(op, rw.sx(a[0]), rw.sx(a[1]))
        else:
            rw.orig[k] = ca.SX.unary(op, rw.sx(a[0]))
        if op == ca.OP_MUL and any(j in const and const[j] != 0.0 for j in a):
            c, v = (a[0], a[1]) if a[0] in const else (a[1], a[0])
            rw.terms_of[k] = [(1.0, const[c], rw.sx(v))]
        elif op in (ca.OP_ADD, ca.OP_SUB) and not any(j in const for j in a):
            sign = -1.0 if op == ca.OP_SUB else 1.0
            rw.terms_of[k] = rw.terms(a[0]) + [(sign * s, c, t) for s, c, t in rw.terms(a[1])]
        cur[out[0]] = k
    return ca.Function(f.name(), args, [ca.vertcat(*o) if o else ca.SX(0, 1) for o in outs],
                       f.name_in(), f.name_out())


__all__ = ["factor_constants"]
