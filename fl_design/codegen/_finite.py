"""Which values the step's one finiteness test must sum: the fewest that still prove the rest.

The generated step stores its results only when one test on the bit pattern of a sum passes
(``PREFIX_finite(sum)``): a NaN or an infinity in any term makes the sum NaN or infinite. The
values that must be finite when the test passes (the *required* ones) are, in the generated
step, the inputs that carry a sample or the state (``x``, ``y``, ``r``) and the input ``u``
it returns; the next state ``x_next`` is finite unless the arithmetic overflows, and the next
sample's test, whose required inputs include the state, rejects an overflowed one (the
caller's choice: :func:`check_terms` proves whatever it is given).
Not all of them need to be terms: a value is known finite when the test passes if

- it is a term, a constant or a truth value;
- it is an operand of a *strict* operation whose result is known finite: ``a + b``, ``a - b``,
  ``a * b``, ``-a``, ``a * a``, ``|a|`` and the numerator of ``a / b`` are NaN or infinite
  whenever an operand is (IEEE 754: ``inf - inf``, ``0 * inf`` are NaN);
- it is a select (``c ? a : b``, ``min``, ``max``, ``c ? a : 0``) all of whose values are known
  finite (the select returns one of them);
- it is a saturation ``min(max(v, lo), hi)`` printed as one ``if``/``else`` (:mod:`._emit`)
  whose input ``v`` is known finite, on the branch where ``lo < v < hi`` held: there the
  result is ``v`` (``v`` is always a term: the comparisons alone would prove it finite under
  IEEE semantics, which ``-ffast-math`` does not keep). Only arithmetic *forward* is never
  trusted (finite operands may overflow).

:func:`check_terms` picks the terms greedily from the required values (so that the test says
"any of x, y, r, x_next, u is not finite", and, on a saturated branch, "or the unsaturated
value v is not finite"): the terms of the common path, where every saturation is inside its
limits (each saturation's ``v`` among them), and for each saturation the term its saturated
branches add (the result, ``lo`` or ``hi`` there; ``v`` is already a term). A non-finite
required value always fails the test; a test that fails with all of them finite (a sum that
overflows, a non-finite ``v`` with a finite result) rejects the sample: the safe side.

Examples
--------
>>> from fl_design.codegen._finite import check_terms
>>> nodes = {0: ("input", ()), 1: ("input", ()), 2: ("strict", (0, 1)),
...          3: ("const", ()), 4: ("sat", (2, 3, 3)), 5: ("strict", (0, 3))}
>>> check_terms(nodes, required=[0, 1, 4, 5], blocks=[4])  # 0, 1 from v = node 2
([2, 5], {4: (2, 4)})
"""

from __future__ import annotations

#: node kinds: "input", "const", "int" (a truth value), "strict" (every operand strict),
#: "div" (the numerator strict), "select" (the value is one of the operands), "sat" ((v, lo,
#: hi): a saturation printed as one if/else), "other" (nothing known)
KINDS = ("input", "const", "int", "strict", "div", "select", "sat", "other")


def known_finite(nodes: dict, facts, blocks_inside=()) -> set:
    """The nodes known finite when every node of ``facts`` is (the rules of the module).

    Parameters
    ----------
    nodes : dict
        ``{id: (kind, operand ids)}`` in evaluation order (kinds: :data:`KINDS`).
    facts : iterable of int
        Nodes known finite (the test's terms).
    blocks_inside : iterable of int
        Saturations (``"sat"`` nodes) on their unsaturated branch: ``v`` finite, result ``v``.

    Returns
    -------
    set of int

    Examples
    --------
    >>> from fl_design.codegen._finite import known_finite
    >>> nodes = {0: ("input", ()), 1: ("input", ()), 2: ("strict", (0, 1)),
    ...          3: ("select", (0, 2))}
    >>> sorted(known_finite(nodes, [2]))  # 2 = 0 + 1: both finite; the select of them too
    [0, 1, 2, 3]
    """
    known = {k for k, (kind, _) in nodes.items() if kind in ("const", "int")}
    known |= set(facts)
    inside = set(blocks_inside)
    known |= {nodes[k][1][0] for k in inside}
    changed = True
    while changed:
        changed = False
        for k in reversed(list(nodes)):  # backward: operands of strict operations
            kind, args = nodes[k]
            if k not in known:
                continue
            strict = args if kind == "strict" else args[:1] if kind in ("div", "sat") else ()
            if kind == "sat" and k not in inside:
                strict = ()
            for a in strict:
                if a not in known:
                    known.add(a)
                    changed = True
        for k, (kind, args) in nodes.items():  # forward: selects, unsaturated saturations
            if k in known:
                continue
            if (kind == "select" and all(a in known for a in args)) or (
                    kind == "sat" and k in inside and args[0] in known):
                known.add(k)
                changed = True
    return known


def check_terms(nodes: dict, required, blocks) -> tuple[list[int], dict[int, tuple[int, int]]]:
    """The terms of the finiteness test: ``(common, {block: (v, result)})`` (see the module).

    Parameters
    ----------
    nodes : dict
        ``{id: (kind, operand ids)}`` (:func:`known_finite`).
    required : iterable of int
        The values that must be finite when the test passes; the terms are chosen among them.
    blocks : iterable of int
        The saturations printed as one ``if``/``else`` (``"sat"`` nodes).

    Returns
    -------
    tuple
        The common path's terms (sorted), and per saturation ``(v, result)``: its saturated
        branches add the result.

    Examples
    --------
    >>> from fl_design.codegen._finite import check_terms
    >>> nodes = {0: ("input", ()), 1: ("strict", (0, 0)), 2: ("other", (0,))}
    >>> check_terms(nodes, required=[0, 1, 2], blocks=[])  # 1 proves 0; 2 is its own term
    ([1, 2], {})
    """
    required, blocks = list(dict.fromkeys(required)), list(blocks)
    # each saturation's input v is a term: its branches' comparisons prove it finite only
    # under IEEE semantics, which -ffast-math does not keep (a NaN may take any branch)
    terms: list[int] = [nodes[k][1][0] for k in blocks]
    known = known_finite(nodes, terms, blocks)
    while not all(k in known for k in required):
        # the term that proves the most required values still open (ties: the latest)
        best, best_known = None, None
        for t in required:
            if t in known:
                continue
            now = known_finite(nodes, [*terms, t], blocks)
            if best is None or sum(k in now for k in required) >= sum(k in best_known
                                                                       for k in required):
                best, best_known = t, now
        terms.append(best)
        known = best_known
    return sorted(set(terms)), {k: (nodes[k][1][0], k) for k in blocks}


__all__ = ["KINDS", "check_terms", "known_finite"]
