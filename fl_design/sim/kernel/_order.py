"""The order in which the lane step's operations are written (values live briefly).

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


__all__ = ["in_place"]
