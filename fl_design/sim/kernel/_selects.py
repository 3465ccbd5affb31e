"""Fewer instructions for the lane step's selects, bit for bit the same values.

CasADi writes ``if_else(c, a, b)`` as ``(c ? a : 0) + (!c ? b : 0)``, which the lane emitter
prints as one select plus ``0.0`` (the addition turns ``-0.0`` into ``+0.0`` and quiets a
signalling NaN, as the sum does). The classifier's accumulators are such selects (under the
step's guard) of selects or extrema of their own old values. Two rewrites here keep every bit:

- :func:`merged`: a select whose chosen value is a select (or ``fmin``/``fmax``) sharing its
  other value is one select on the combined mask;
- :class:`Zeros`: the ``+ 0.0`` of a select is dropped where both values are already
  *normal* (neither ``-0.0`` nor a signalling NaN), tracked through the step: results of
  arithmetic are quiet, a sum is ``-0.0`` only if both terms are, ``fabs`` is never ``-0.0``,
  a select plus ``0.0`` is normal. An accumulator entry every step stores a normal value into
  is normal from the second step on; its initial values are checked by the kernel (it
  returns 2 when one is not normal, and the runner then runs the exact scalar kernel).

Examples
--------
>>> from fl_design.sim.kernel._selects import merged
>>> merged(("g", "v2", "v1"), {"v2": ("n", "v0", "v1")})
('(g & n)', 'v0', 'v1')
"""

from __future__ import annotations

import casadi as ca

from ._vector import BINARY


def select_parts(node: dict, x: str, y: str, mask) -> tuple[str, str, str] | None:
    """``(mask, a, b)`` of :func:`fl_design.sim.kernel._emit._select`'s ``(FL_SEL(mask, a, b)+FL_Z)``, or None."""
    nx, ny = node.get(x), node.get(y)
    if not (nx and ny and nx[0] == ny[0] == ca.OP_IF_ELSE_ZERO):
        return None
    (_, cx, ax), (_, cy, by) = nx, ny
    if node.get(cy) == (ca.OP_NOT, cx):
        return mask(cx), ax, by
    if node.get(cx) == (ca.OP_NOT, cy):
        return mask(cy), by, ax
    return None


def merged(parts: tuple[str, str, str], selects: dict) -> tuple[str, str, str]:
    """A select whose chosen value is itself a select with the same other value, as one.

    ``sel(m, sel(n, a, b) [+ 0], b) + 0`` is ``sel(m & n, a, b) + 0`` bit for bit (``m``:
    the inner sum plus zero again is itself; not ``m``: ``b + 0`` either way), and likewise
    with the inner select in the other branch or choosing the other way (``~n``, ``m | n``).
    The inner select (also ``fmin``/``fmax``, selects without the ``+ 0``) is then not
    computed: the step's guard selects every accumulator update, most of which are selects
    or extrema on their own old value: one blend each instead of two.

    Examples
    --------
    >>> from fl_design.sim.kernel._selects import merged
    >>> merged(("g", "v2", "v1"), {"v2": ("n", "v0", "v1")})
    ('(g & n)', 'v0', 'v1')
    >>> merged(("g", "v2", "v1"), {"v2": ("n", "v1", "v0")})
    ('(g & ~n)', 'v0', 'v1')
    """
    m, a, b = parts
    inner = selects.get(a)
    if inner is not None and inner[2] == b:
        return f"({m} & {inner[0]})", inner[1], b
    if inner is not None and inner[1] == b:  # sel(m, sel(n, b, c), b) + 0
        return f"({m} & ~{inner[0]})", inner[2], b
    inner = selects.get(b)
    if inner is not None and inner[1] == a:  # sel(m, a, sel(n, a, c)) + 0
        return f"({m} | {inner[0]})", a, inner[2]
    if inner is not None and inner[2] == a:  # sel(m, a, sel(n, c, a)) + 0
        return f"({m} | ~{inner[0]})", a, inner[1]
    return parts



#: ``fmin``/``fmax`` as :data:`BINARY` writes them, ``FL_SEL(mask, {0}, {1})``: the mask.
EXTREMA = {ca.OP_FMIN: "(({0}<{1}) | ({1}!={1}))", ca.OP_FMAX: "(({0}>{1}) | ({1}!={1}))"}
assert all(BINARY[op] == f"FL_SEL({m[1:-1]}, {{0}}, {{1}})" for op, m in EXTREMA.items())




#: How each kind of value is normal: ``(quiet, never -0.0)`` from its arguments' facts.
_ARITH = {ca.OP_MUL, ca.OP_DIV, ca.OP_SQ, ca.OP_TWICE, ca.OP_INV, ca.OP_POW, ca.OP_CONSTPOW}


class Zeros:
    """Which values of the step are normal (neither ``-0.0`` nor a signalling NaN).

    :meth:`fact` records each value as the emitter writes it; :meth:`solve` finds the
    accumulator entries that stay normal (the largest set whose every store is normal when
    their loads are), then which selects need no ``+ 0.0``.
    """

    def __init__(self):
        self.facts: dict[str, tuple] = {}
        self.stores: dict[int, str] = {}
        self.selects: list[tuple[int, tuple[str, str, str]]] = []

    def fact(self, name: str, kind: str, *args) -> None:
        """``kind``: ``load`` (entry), ``normal``, ``quiet`` (arithmetic), ``add``, ``sub``,
        ``fabs``, ``sel`` (one of two values), ``and`` (a value or +0.0)."""
        self.facts[name] = (kind, *args)

    def _normal(self, name: str, entries: set, memo: dict) -> tuple[bool, bool]:
        if name in memo:
            return memo[name]
        memo[name] = (False, False)  # no cycles in SSA; a guard all the same
        kind, *args = self.facts.get(name, ("unknown",))
        sub = [self._normal(a, entries, memo) for a in args if isinstance(a, str)]
        if kind == "load":
            ok = args[0] in entries
            out = (ok, ok)
        elif kind == "normal":
            out = (True, True)
        elif kind == "quiet":
            out = (True, False)
        elif kind == "add":  # -0.0 only as -0.0 + -0.0
            out = (True, sub[0][1] or sub[1][1])
        elif kind == "sub":  # -0.0 only as -0.0 - +0.0
            out = (True, sub[0][1])
        elif kind == "fabs":
            out = (sub[0][0], True)
        elif kind in ("sel", "and"):
            out = (all(q for q, _ in sub), all(z for _, z in sub))
        else:
            out = (False, False)
        memo[name] = out
        return out

    def normal(self, name: str, entries: set, memo: dict) -> bool:
        return all(self._normal(name, entries, memo))

    def solve(self) -> tuple[set[int], set[int]]:
        """``(entries, plain)``: the entries that stay normal, and the indices (as given to
        :meth:`select`) of the selects that need no ``+ 0.0``."""
        entries = {e for e, name in self.stores.items() if self.facts.get(name) != ("load", e)}
        while True:
            memo: dict = {}
            kept = {e for e in entries if self.normal(self.stores[e], entries, memo)}
            if kept == entries:
                break
            entries = kept
        memo = {}
        plain = {i for i, (m, a, b) in self.selects
                 if self.normal(a, entries, memo) and self.normal(b, entries, memo)}
        return entries, plain


__all__ = ["EXTREMA", "Zeros", "merged", "select_parts"]
