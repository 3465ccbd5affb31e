"""Tidying SymPy expressions of a plant: real-variable simplification, no Dirac deltas.

Examples
--------
>>> import sympy as sp
>>> from fl_design.symbolic._tidy import tidy
>>> x = sp.Symbol("x", real=True)
>>> tidy(x**3 * sp.sign(x) + x * sp.sign(x))
(x**2 + 1)*Abs(x)
"""

from __future__ import annotations

import sympy as sp


def _real_maps(symbols) -> tuple[dict, dict]:
    """Real-valued stand-ins for symbols without the real assumption (and the map back)."""
    fwd, back = {}, {}
    for s in symbols:
        if s.is_real:
            continue
        r = sp.Dummy(s.name, real=True)
        fwd[s], back[r] = r, s
    return fwd, back


def _drop_dirac(expr: sp.Expr) -> sp.Expr:
    return expr.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.S.Zero)


def _abs_rule(e: sp.Expr) -> sp.Expr:
    """``z^k sign(z) -> z^(k-1) |z|`` inside a product (exact for real z, zero included)."""
    factors = list(e.args)
    changed = True
    while changed:
        changed = False
        for f in factors:
            if not isinstance(f, sp.sign):
                continue
            z = f.args[0]
            power = next((g for g in factors if g == z or (
                g.is_Pow and g.base == z and g.exp.is_Integer and g.exp > 1)), None)
            if power is not None:
                factors.remove(f)
                factors.remove(power)
                factors.append(sp.Abs(z) * (z ** (power.exp - 1) if power.is_Pow else 1))
                changed = True
                break
    return sp.Mul(*factors)


def tidy(expr: sp.Expr) -> sp.Expr:
    """Light, fast clean-up of a derived expression (no general ``simplify``)."""
    expr = sp.expand(expr)
    expr = expr.replace(lambda e: e.is_Mul, _abs_rule)
    return sp.factor_terms(expr)


__all__ = ["tidy"]
