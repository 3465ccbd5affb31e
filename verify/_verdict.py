"""How a verify script ends: the machine's load, then ``holds`` or ``FAILS`` and the exit status.

Imported by the scripts next to it (their folder is on ``sys.path`` when run as a script).
"""

from __future__ import annotations

import os


def load_line() -> str:
    """``load average (1, 5, 15 min): a, b, c``: how busy the machine was for the timings."""
    return "load average (1, 5, 15 min): " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def finish(ok: bool) -> int:
    """Print :func:`load_line` and ``holds`` or ``FAILS``; the exit status (0 when ``ok``)."""
    print(load_line())
    print("holds" if ok else "FAILS")
    return 0 if ok else 1
