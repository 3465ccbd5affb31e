"""A rig's log read and checked: columns ``t, y, u`` (``r`` optional), sampling time and jitter.

A log is a CSV file with a header row (any controller's log: ``u`` is what was applied) or a
mapping of column arrays (e.g. :func:`fl_design.read_telemetry`'s columns, a
:class:`fl_design.sim._rig.RigLog`'s :meth:`columns`). Column names are matched without case
and surrounding spaces; other columns are kept aside and listed. A log without ``t`` but with a
sample index (``k``, ``sample``, ``sample_index`` or ``index``, as a telemetry frame carries)
is dated ``t = k T`` when ``T`` is given.

Nothing is dropped silently. Rows with a missing or non-finite value, a repeated time stamp, or
a time step that breaks the sampling are errors naming the first such row (its line in the CSV
file, header = line 1) and how many there are; with ``bad_rows="skip"`` they are skipped,
counted with their reason, and the log is cut into contiguous segments there (no estimate spans
a cut). Time going backwards is always an error. The sampling time is the median time step; a
time step longer than :data:`GAP_FACTOR` times the median is a gap, one shorter than the median over
:data:`SHORT_FACTOR` is another unit (mixed units), and a
median step outside :data:`T_PLAUSIBLE` is refused as implausible (milliseconds given as
seconds, or the reverse); so is a log whose time stamps are whole numbers stepping by one or more
(a millisecond counter) unless ``T`` says so.

Examples
--------
>>> import numpy as np
>>> from fl_design.identification._log import read_log
>>> t = np.arange(1000) * 1e-3
>>> log = read_log({"t": t, "y": np.sin(t), "u": np.cos(7 * t)})
>>> round(log.T, 6), log.n, log.skipped
(0.001, 1000, {})
"""

from __future__ import annotations

import csv
import difflib
import io
import itertools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import LogError

#: Required and optional columns.
REQUIRED = ("t", "y", "u")
OPTIONAL = ("r",)
#: Sample-index columns that date a log without ``t`` when ``T`` is given (telemetry frames).
INDEX_NAMES = ("k", "sample", "sample_index", "index")
#: Fewest usable samples.
MIN_SAMPLES = 200
#: A time step longer than this factor times the median is a gap; shorter than the median over
#: SHORT_FACTOR, another unit (jitter in between is measured, not refused).
GAP_FACTOR, SHORT_FACTOR = 1.5, 10.0
#: Plausible sampling times [s].
T_PLAUSIBLE = (1e-6, 1.0)
#: Largest log accepted (rows).
MAX_ROWS = 20_000_000


@dataclass(frozen=True)
class Log:
    """A checked log: uniform samples in contiguous segments.

    Parameters
    ----------
    t, y, u : numpy.ndarray
        The kept rows.
    r : numpy.ndarray or None
        The reference, if logged.
    T : float
        Sampling time [s] (median time step).
    jitter : float
        Standard deviation of the time steps within segments [s].
    jitter_max : float
        Largest ``|dt - T|`` within segments [s].
    segments : tuple of (int, int)
        ``[start, stop)`` of each contiguous run of kept rows.
    skipped : dict
        Reason -> number of rows skipped.
    first_skipped : dict
        Reason -> the first skipped row's line (CSV) or index (arrays).
    extra : tuple of str
        Columns not used.
    source : str
        The file or ``"<columns>"``.
    """

    t: np.ndarray
    y: np.ndarray
    u: np.ndarray
    r: np.ndarray | None
    T: float
    jitter: float
    jitter_max: float
    segments: tuple
    skipped: dict = field(default_factory=dict)
    first_skipped: dict = field(default_factory=dict)
    extra: tuple = ()
    source: str = "<columns>"

    @property
    def n(self) -> int:
        """Number of kept samples."""
        return int(self.t.size)

    @property
    def duration(self) -> float:
        """Seconds covered by the kept samples."""
        return float(self.n * self.T)


def _where(i: int, csv_file: bool) -> str:
    return f"line {i + 2}" if csv_file else f"row {i}"


def _columns_from_csv(path: Path) -> dict:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as err:
        raise LogError(f"cannot read the log {str(path)!r}: "
                       f"{getattr(err, 'strerror', None) or type(err).__name__}") from None
    reader = csv.reader(io.StringIO(text))
    try:
        header = next(reader)
    except StopIteration:
        raise LogError(f"the log {str(path)!r} is empty: it needs a header row naming the "
                       f"columns t, y, u (r optional) and one row per sample") from None
    names = [h.strip().lower() for h in header]
    if all(_is_number(h) for h in names if h):
        raise LogError(f"the log {str(path)!r} has no header row (line 1 is numbers: "
                       f"{','.join(header[:4])}...): add one naming the columns, e.g. t,y,u,r")
    rows = list(reader)
    if len(rows) > MAX_ROWS:
        raise LogError(f"the log has {len(rows)} rows, above {MAX_ROWS}: split it")
    keep = {n: i for i, n in enumerate(names)}
    try:  # the fast path: every cell a number, every row complete
        block = np.array(rows, dtype=float)
        if block.ndim == 2 and block.shape[1] == len(names):
            return {name: block[:, j] for name, j in keep.items()}
    except ValueError:
        pass  # a missing or bad cell: found below, with its line
    cols = {}
    for name, j in keep.items():
        col = np.full(len(rows), np.nan)
        for i, row in enumerate(rows):
            cell = row[j].strip() if j < len(row) else ""
            if cell == "" or cell.lower() == "nan":
                continue  # missing: NaN, counted later with its row
            try:
                col[i] = float(cell)
            except ValueError:
                if name in REQUIRED + OPTIONAL:
                    raise LogError(f"the log's column {name!r} at line {i + 2} is "
                                   f"{cell[:30]!r}, not a number: every cell of t, y, u, r "
                                   f"must be a number") from None
                col[i] = np.nan
        cols[name] = col
    return cols


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def _pick(cols: dict, where: str, T: float | None = None) -> tuple[dict, tuple]:
    names = {str(k).strip().lower(): k for k in cols}
    index = next((k for k in INDEX_NAMES if k in names), None)
    if "t" not in names and index is not None:  # a telemetry frame: sample index, no clock
        if T is None:
            raise LogError(f"{where}: the log has a sample index {index!r} but no time column "
                           f"'t': give T=... (the sampling time) to date its samples")
        try:
            k = np.asarray(cols[names[index]], dtype=float).ravel()
        except (TypeError, ValueError):
            raise LogError(f"{where}: the column {index!r} is not numbers") from None
        cols = dict(cols)
        cols["t"] = k * float(T)
        names["t"] = "t"
    missing = [c for c in REQUIRED if c not in names]
    if missing:
        found = sorted(names)
        hint = []
        for c in missing:
            near = difflib.get_close_matches(c, found, n=1, cutoff=0.0) if c != "t" else \
                [f for f in found if f in ("time", "timestamp", "time_s", "sec", "ts")]
            if near:
                hint.append(f"is {near[0]!r} the column {c!r}? rename it")
        raise LogError(f"{where}: the log misses the column(s) {', '.join(map(repr, missing))} "
                       f"(found {', '.join(map(repr, found)) or 'none'}); it needs t [s], y "
                       f"(measured output), u (applied input), and optionally r"
                       + (f"; {'; '.join(hint)}" if hint else ""))
    out = {}
    for c in REQUIRED + OPTIONAL:
        if c in names:
            try:
                arr = np.asarray(cols[names[c]], dtype=float).ravel()
            except (TypeError, ValueError):
                raise LogError(f"{where}: the column {c!r} is not numbers") from None
            out[c] = arr
    sizes = {c: a.size for c, a in out.items()}
    if len(set(sizes.values())) > 1:
        raise LogError(f"{where}: the columns have different lengths {sizes}")
    extra = tuple(sorted(n for n in names if n not in REQUIRED + OPTIONAL + INDEX_NAMES))
    return out, extra


def read_log(log, *, bad_rows: str = "error", T: float | None = None) -> Log:
    """Read and check a log (a CSV path or a mapping of columns); see the module.

    Parameters
    ----------
    log : str, pathlib.Path or mapping
        A CSV file with a header, or columns ``{"t": ..., "y": ..., "u": ..., "r": ...}``.
    bad_rows : {"error", "skip"}, optional
        What to do with rows that cannot be used (default: an error naming the first).
    T : float, optional
        The sampling time you expect [s]; the time stamps must agree within 1 %.

    Returns
    -------
    Log

    Raises
    ------
    LogError
        Missing or misnamed columns, a non-numeric cell, NaNs, time going backwards or
        repeated, gaps, an implausible sampling time, too few samples (each naming the row or
        column and what is needed).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(300) * 1e-3
    >>> try:
    ...     read_log({"time": t, "y": t, "u": t})
    ... except Exception as err:
    ...     print(str(err)[:60])
    <columns>: the log misses the column(s) 't' (found 'time', '
    """
    if bad_rows not in ("error", "skip"):
        raise LogError(f"bad_rows={bad_rows!r}: give 'error' or 'skip'")
    if isinstance(log, (str, Path)):
        path = Path(log)
        where, csv_file = str(path), True
        cols, extra = _pick(_columns_from_csv(path), where, T)
    elif hasattr(log, "keys"):
        where, csv_file = "<columns>", False
        cols, extra = _pick(log, where, T)
    else:
        raise LogError(f"log must be a CSV file path or a mapping of columns t, y, u (r "
                       f"optional), got {type(log).__name__}")
    t, n0 = cols["t"], cols["t"].size
    skipped, first = {}, {}

    def skip(reason, mask, hint):
        idx = np.flatnonzero(mask)
        if not idx.size:
            return mask
        if bad_rows == "error":
            raise LogError(f"{where}: {reason} at {_where(int(idx[0]), csv_file)} "
                           f"({idx.size} row(s) in all); {hint}, or pass bad_rows='skip' to "
                           f"skip such rows (they are counted)")
        skipped[reason] = skipped.get(reason, 0) + int(idx.size)
        first[reason] = _where(int(idx[0]), csv_file)
        return mask

    bad = np.zeros(n0, dtype=bool)
    for c, arr in cols.items():
        m = ~np.isfinite(arr)
        if c == "r" and m.all():
            continue
        skip(f"a missing or non-finite value in column {c!r}", m & ~bad,
             f"fill or remove those rows of {c!r}")
        bad |= m
    idx = np.flatnonzero(~bad)
    if idx.size >= 2:
        dt = np.diff(t[idx])
        back = np.flatnonzero(dt < 0)
        if back.size:
            i = int(idx[back[0] + 1])
            raise LogError(f"{where}: time goes backwards at {_where(i, csv_file)} (t = "
                           f"{t[i]:.9g} after {t[idx[back[0]]]:.9g}); sort the log by t or "
                           f"remove the restarted part ({back.size} such step(s))")
        dup = np.zeros(n0, dtype=bool)
        dup[idx[1:][dt == 0]] = True
        skip("a repeated time stamp", dup, "remove the repeated rows")
        bad |= dup
    idx = np.flatnonzero(~bad)
    if idx.size < MIN_SAMPLES:
        raise LogError(f"{where}: {idx.size} usable samples (of {n0} rows); at least "
                       f"{MIN_SAMPLES} are needed (a few seconds at the loop's rate)")
    dt = np.diff(t[idx])
    Tm = float(f"{float(np.median(dt)):.9g}")  # time stamps carry no more digits than this
    if not T_PLAUSIBLE[0] <= Tm <= T_PLAUSIBLE[1]:
        raise LogError(f"{where}: the median time step is {Tm:.6g}, an implausible sampling "
                       f"time in seconds (plausible: {T_PLAUSIBLE[0]:g} to {T_PLAUSIBLE[1]:g} s)"
                       f": is t in {'milliseconds or microseconds' if Tm > 1 else 'another unit'}"
                       f"? give t in seconds")
    if T is None and Tm >= 0.5 and np.all(t[idx] == np.round(t[idx])):
        raise LogError(f"{where}: the time stamps are whole numbers stepping by {Tm:g}: a "
                       f"millisecond (or sample) counter read as seconds? give t in seconds, "
                       f"or T={Tm:g} if the loop really samples every {Tm:g} s")
    if T is not None and abs(Tm - float(T)) > 0.01 * float(T):
        raise LogError(f"{where}: the time stamps step by {Tm:.6g} s, not the T = {T:g} s you "
                       f"gave: mixed units (ms and s) or another rate? give t in seconds")
    consecutive = np.diff(idx) == 1  # a skipped row cuts the log there (already counted)
    off = np.flatnonzero(((dt > GAP_FACTOR * Tm) | (dt < Tm / SHORT_FACTOR)) & consecutive)
    cuts = sorted(set(np.flatnonzero(~consecutive) + 1))
    if off.size:
        i = int(idx[off[0] + 1])
        if bad_rows == "error":
            raise LogError(f"{where}: the time step before {_where(i, csv_file)} is "
                           f"{dt[off[0]]:.6g} s, the median {Tm:.6g} s: a gap, dropped "
                           f"samples or mixed units ({off.size} such step(s)); give a uniformly "
                           f"sampled log in seconds, or bad_rows='skip' to cut it into segments")
        skipped["a time step off the median (segment cut, no row dropped)"] = int(off.size)
        first["a time step off the median (segment cut, no row dropped)"] = _where(i, csv_file)
        cuts = sorted(set(cuts) | set(off + 1))
    keep = idx
    bounds = [0] + cuts + [keep.size]
    segments = tuple((a, b) for a, b in itertools.pairwise(bounds) if b - a >= 2)
    inside = np.concatenate([np.diff(t[keep][a:b]) for a, b in segments]) if segments else dt
    r = cols.get("r")
    if r is not None and not np.all(np.isfinite(r[keep])):
        r = None
    return Log(t=t[keep], y=cols["y"][keep], u=cols["u"][keep],
               r=None if r is None else r[keep], T=Tm, jitter=float(np.std(inside)),
               jitter_max=float(np.max(np.abs(inside - Tm))), segments=segments,
               skipped=skipped, first_skipped=first, extra=extra, source=where)


__all__ = ["Log", "read_log"]
