"""This machine's process table, read from Linux ``/proc``: who is alive, stopped, using CPU.

The executor's heartbeat (:mod:`fl_design.sim._executor`) uses it to tell a stopped or
deadlocked worker process (no CPU used, itself and the compilers it started) from a busy one.
Elsewhere (no ``/proc``) :func:`proc_stats` is None and only the grid's time limit applies.

Examples
--------
>>> import os
>>> from fl_design.sim._procs import proc_stats, tree_cpu
>>> stats = proc_stats()
>>> stats is None or (os.getpid() in stats and tree_cpu(stats, os.getpid()) >= 0)
True
"""

from __future__ import annotations

import os


def proc_stats() -> dict | None:
    """``{pid: (ppid, state, cpu ticks)}`` of this machine's processes (Linux ``/proc``);
    None where there is no ``/proc``.

    Examples
    --------
    >>> import os
    >>> from fl_design.sim._procs import proc_stats
    >>> stats = proc_stats()
    >>> stats is None or stats[os.getpid()][1] in "RS"
    True
    """
    if not os.path.isdir("/proc/self/task"):
        return None
    stats = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as fh:
                text = fh.read().decode("ascii", "replace")
        except OSError:
            continue
        fields = text[text.rfind(")") + 2:].split()
        try:
            stats[int(name)] = (int(fields[1]), fields[0], int(fields[11]) + int(fields[12]))
        except (IndexError, ValueError):
            continue
    return stats


def tree_cpu(stats: dict, pid: int) -> int:
    """CPU ticks of ``pid`` and its descendants (a worker and the compiler it runs).

    Examples
    --------
    >>> from fl_design.sim._procs import tree_cpu
    >>> tree_cpu({1: (0, "S", 5), 2: (1, "R", 7), 3: (9, "R", 100)}, 1)
    12
    """
    children: dict = {}
    for p, (ppid, _, _) in stats.items():
        children.setdefault(ppid, []).append(p)
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        if p in stats:
            total += stats[p][2]
            todo.extend(children.get(p, ()))
    return total


__all__ = ["proc_stats", "tree_cpu"]
