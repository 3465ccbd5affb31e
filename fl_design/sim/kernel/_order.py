"""Arranging the lane step's operations: the order they are written in (values live briefly),
and what depends only on a run's read-only entries (computed once per run: :func:`hoist`).

Examples
--------
>>> from fl_design.sim.kernel._order import in_place
>>> ops = [("in", (0, 0), "v0"), ("let", "(v0+v0)", "v1"), ("out", (0, 0), "v1")]
>>> [name for _, _, name in in_place(ops, None)[0]]
['v0', 'v1', 'v1']
"""

from __future__ import annotations

import re


def in_place(ops: list, call: int | None) -> tuple[list, int | None]:
    """The step's operations in the order they are written, and the call's index.

    Outputs that only copy their own input are dropped (the step updates ``A`` in place).
    The rest is ordered depth first from the roots, the call then each output in turn: an
    operation comes just before the first one that needs it, an output is stored as soon as
    its value exists (after the load of the entry it overwrites). Values then live briefly:
    with 16 vector registers (AVX2) the order decides how much is spilled, and everything
    alive across a call of vector math is saved and restored around it.
    """
    loads = {name: data for kind, data, name in ops if kind == "in"}
    kept = [op for op in ops if op[0] != "out" or loads.get(op[2]) != (0, op[1][1])]
    producer, load_of = {}, {}
    for i, (kind, data, name) in enumerate(kept):
        if kind == "call":
            producer.update((n, i) for n in name)
        elif kind != "out":
            producer[name] = i
            if kind == "in" and data[0] == 0:
                load_of[data[1]] = i

    def needs(i: int) -> list[int]:
        kind, data, name = kept[i]
        if kind == "in":
            return []
        if kind == "call":
            names = data
        elif kind == "out":
            names = [name]
            if data[1] in load_of:  # the entry is read before it is overwritten
                names = [kept[load_of[data[1]]][2], name]
        else:
            names = re.findall(r"\b[vc]\d+\b", data)
        return [producer[n] for n in names if n in producer]

    order, done = [], set()
    roots = [i for i, op in enumerate(kept) if op[0] == "call"] + \
        [i for i, op in enumerate(kept) if op[0] == "out"]
    for root in roots:
        stack = [(root, iter(needs(root)))]
        while stack:
            i, todo = stack[-1]
            j = next((j for j in todo if j not in done), None)
            if j is not None:
                done.add(j)
                stack.append((j, iter(needs(j))))
                continue
            stack.pop()
            done.add(i)
            order.append(kept[i])
    if call is None:
        return order, None
    return order, next(i for i, op in enumerate(order) if op[0] == "call")


_NAMES = re.compile(r"\b[vc]\d+\b")


def hoist(ops: list, nacc: int) -> tuple[list, list, int]:
    """The values that depend only on read-only accumulator entries, computed once per run.

    A value whose operands are constants and entries the step never writes (a run's gains,
    limits, windows...) is the same at every step: those needed by the rest of the step are
    computed by ``fl_lanes_init`` when lanes are (re)filled and stored as extra entries
    ``nacc, nacc + 1, ...`` of ``A``, where the step loads them (the same operations on the
    same values: the same bits).

    Parameters
    ----------
    ops : list
        The step's operations in the order they are written (:func:`in_place`).
    nacc : int
        Accumulator entries (the extra ones follow).

    Returns
    -------
    (list, list, int)
        The step's operations (those values loaded), the initialisation's (computing and
        storing them) and their number.

    Examples
    --------
    >>> from fl_design.sim.kernel._order import hoist
    >>> ops = [("in", (0, 1), "v0"), ("let", "(v0*v0)", "v1"), ("in", (0, 0), "v2"),
    ...        ("let", "(v2+v1)", "v3"), ("out", (0, 0), "v3")]
    >>> step, init, n = hoist(ops, 2)
    >>> step[1], init[-1], n
    (('in', (0, 2), 'v1'), ('out', (0, 2), 'v1'), 1)
    """
    written = {data[1] for kind, data, _ in ops if kind == "out" and data[0] == 0}
    fixed: set[str] = set()
    for kind, data, name in ops:
        read_only = kind == "in" and data[0] == 0 and data[1] not in written
        if read_only or (kind == "let" and all(n in fixed for n in _NAMES.findall(data))):
            fixed.add(name)
    needed = set()  # fixed values the step uses that are computed (not a load or constant)
    for kind, data, name in ops:
        if kind == "call":
            uses = data
        elif kind == "out":
            uses = [name]
        elif kind == "let" and name not in fixed:
            uses = _NAMES.findall(data)
        else:
            continue
        needed.update(n for n in uses if n in fixed)
    lets = {name for kind, data, name in ops if kind == "let" and _NAMES.search(data)}
    slots = {}
    for kind, _, name in ops:
        if kind == "let" and name in needed and name in lets and name not in slots:
            slots[name] = nacc + len(slots)
    if not slots:
        return ops, [], 0
    step = [("in", (0, slots[name]), name) if kind == "let" and name in slots else
            (kind, data, name) for kind, data, name in ops]
    init = [op for op in ops if op[0] in ("in", "let") and op[2] in fixed]
    init += [("out", (0, slot), name) for name, slot in slots.items()]
    return step, init, len(slots)


__all__ = ["hoist", "in_place"]
