"""What the verify scripts share: a log-log slope, the load line, how a claim's verdict ends.

Imported by the scripts next to it (their folder is on ``sys.path`` when run as a script).
"""

from __future__ import annotations

import argparse
import os

import numpy as np


def slope(x, y) -> float:
    """Slope of the least-squares line through ``(log x, log y)``: the exponent of ``y ~ x^p``."""
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def load_line() -> str:
    """``load average (1, 5, 15 min): a, b, c``: how busy the machine was for the timings."""
    return "load average (1, 5, 15 min): " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def machine() -> str:
    """CPU, cores, the kernels' instruction-set level and the load average."""
    import fl_design as fl

    d = fl.Kernel().describe()
    return (f"machine: {d['cpu']} ({d['machine']}), {os.cpu_count()} cores; kernel ISA "
            f"{d['isa']} ({d['isa_source']}, {d['lanes']} lanes; available "
            f"{', '.join(d['available'])}); load average "
            + ", ".join(f"{x:.2f}" for x in os.getloadavg()))


def quick_args(doc: str, quick_help: str, argv=None) -> argparse.Namespace:
    """The command line of a script whose only option is ``--quick`` (``quick_help`` says what
    it shortens); its description is the first line of ``doc``."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=quick_help)
    return parser.parse_args(argv)


def finish(ok: bool) -> int:
    """Print :func:`load_line` and ``holds`` or ``FAILS``; the exit status (0 when ``ok``)."""
    print(load_line())
    print("holds" if ok else "FAILS")
    return 0 if ok else 1


def claim_verdict(number: int, statement: str, ok: bool, meaning: str | None = None) -> int:
    """Print ``What it means: ...`` (when given), then ``claim N (statement): holds`` (or
    ``FAILS``); the exit status (0 when ``ok``)."""
    if meaning:
        print(f"What it means: {meaning}")
    print(f"\nclaim {number} ({statement}): {'holds' if ok else 'FAILS'}")
    return 0 if ok else 1


#: Environment variable naming the file where :func:`target` appends its records (set by
#: ``docs/generate.py`` for the README's performance table; unset, nothing is written).
TARGETS_ENV = "FL_DESIGN_TARGETS"


def target(name: str, value: float, limit: float, *, unit: str = "s", at_least: bool = False,
           checked: bool = True, detail: str = "") -> bool:
    """Whether a measured ``value`` meets its ``limit`` (``<=``, or ``>=`` with ``at_least``);
    also appends one JSON line to the file named by ``$FL_DESIGN_TARGETS`` when it is set.

    ``checked=False`` records a number measured where the target is not judged (``--quick``,
    or a load that makes the timing meaningless): the table shows it as "not checked". The
    record names the script, the machine (CPU, kernel ISA), the load and the UTC time, so the
    README's table (``docs/generate.py``) says where each number comes from.
    """
    import datetime
    import json
    import sys
    from pathlib import Path

    met = bool(value >= limit if at_least else value <= limit)
    out = os.environ.get(TARGETS_ENV)
    if out:
        import fl_design as fl

        d = fl.Kernel().describe()
        rec = {"script": Path(sys.argv[0]).stem, "name": name, "value": float(value),
               "limit": float(limit), "unit": unit, "relation": ">=" if at_least else "<=",
               "met": met, "checked": bool(checked), "detail": detail,
               "cpu": d["cpu"], "isa": d["isa"], "cores": os.cpu_count(),
               "load": round(os.getloadavg()[0], 2),
               "utc": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M")}
        with open(out, "a", encoding="utf-8") as f:
            f.write(json.dumps(rec) + "\n")
    return met
