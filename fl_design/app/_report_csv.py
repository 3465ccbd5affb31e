"""The runs as CSV files under ``runs/``: bounded by default, every sample on request.

A compared run of a fast loop holds many samples (30 s at ``T = 10 us`` is 3 million rows,
about 750 MB of text): each file holds at most :data:`CSV_MAX_ROWS` rows, every k-th sample
with the first and the last, numbers exact (``repr``); ``fl-design run --full-csv`` writes
every sample. The report and ``summary.json`` say which.

Examples
--------
>>> from fl_design.app._report_csv import CSV_MAX_ROWS
>>> CSV_MAX_ROWS
10000
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

#: Most rows of one run's CSV file (without ``--full-csv``).
CSV_MAX_ROWS = 10_000


def csv_rows(n: int, most: int | None) -> np.ndarray:
    """The sample indices a CSV of ``n`` samples keeps: all, or every k-th and the last.

    Parameters
    ----------
    n : int
        Samples of the run.
    most : int or None
        Most rows (None: all).

    Examples
    --------
    >>> from fl_design.app._report_csv import csv_rows
    >>> csv_rows(10, 4).tolist(), csv_rows(3, None).tolist()
    ([0, 3, 6, 9], [0, 1, 2])
    """
    if most is None or n <= most:
        return np.arange(n)
    step = -(-(n - 1) // (most - 1))
    idx = np.arange(0, n, step)
    return idx if idx[-1] == n - 1 else np.append(idx, n - 1)


def csv_text(resp, most: int | None = CSV_MAX_ROWS) -> str:
    """A run's columns (:meth:`fl_design.Response.columns`) as CSV, at most ``most`` rows.

    Parameters
    ----------
    resp : fl_design.Response
        A run.
    most : int or None, optional
        Most rows (None: every sample, as :meth:`~fl_design.Response.to_csv`).

    Examples
    --------
    >>> from fl_design.app._report_csv import csv_text
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 1.0))
    >>> len(csv_text(r, 100).splitlines()) - 1 <= 100, csv_text(r, None) == r.to_csv()
    (True, True)
    """
    cols = resp.columns()
    idx = csv_rows(len(cols["t"]), most)
    rows = zip(*(map(repr, np.asarray(c, dtype=float)[idx].tolist()) for c in cols.values()))
    return ",".join(cols) + "\n" + "".join(f"{','.join(row)}\n" for row in rows)


def run_csv_name(design: str, std: float) -> str:
    """File name of a compared run's CSV: ``runs/<design>_noise<std>.csv`` (safe characters).

    Parameters
    ----------
    design : str
        The design's label (``"EHGO eps=0.05"``, ``"LS(9)"``, or ``"main"``).
    std : float
        Noise standard deviation of the run.

    Examples
    --------
    >>> from fl_design.app._report_csv import run_csv_name
    >>> run_csv_name("LS(9)", 0.001), run_csv_name("EHGO eps=0.05", 0.0)
    ('runs/LS9_noise0.001.csv', 'runs/EHGO_eps0.05_noise0.csv')
    """
    import re

    safe = re.sub(r"[^A-Za-z0-9.]+", "_", design.replace("(", "").replace(")", "")).strip("_")
    safe = safe.replace("_eps_", "_eps").replace("eps_", "eps")
    return f"runs/{safe}_noise{std:g}.csv"


def write_runs_csv(job, folder, *, main: bool = False, full: bool = False) -> list:
    """Write the compared runs (and, with ``main``, the main run) as CSV under
    ``folder/runs``; return the relative paths.

    Each file holds at most :data:`CSV_MAX_ROWS` rows (every k-th sample, the last one
    included, numbers exact: :func:`csv_text`); ``full`` writes every sample
    (``fl-design run --full-csv``).

    Without ``main``, a main-run CSV this folder holds from fl_design's own earlier run
    (recorded in its marker, unchanged) is removed, so the folder never pairs this report with
    an older main run; a file fl_design did not write is left alone.

    Parameters
    ----------
    job : Job
        A job (nothing is written without its simulate stage).
    folder : str or pathlib.Path
        The report's folder.
    main : bool, optional
        Also write the main run (``runs/main_noise<std>.csv``; opt-in).
    full : bool, optional
        Every sample instead of at most :data:`CSV_MAX_ROWS` rows per file.

    Returns
    -------
    list of str
        The files written, relative to ``folder`` (``runs/<design>_noise<std>.csv``).

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_csv import write_runs_csv
    >>> write_runs_csv(run_job(load_config(None), quick=True, stages=("derive",),
    ...                        progress=False), ".")
    []
    """
    sim = job.results.get("simulate")
    if not sim:
        return []
    runs = dict(sim["runs"])
    main_key = ("main", job.config.scenario.noise_std)
    if main:
        runs[main_key] = sim["main"]
    else:
        _remove_own(Path(folder), run_csv_name(*main_key))
    out = Path(folder) / "runs"
    out.mkdir(exist_ok=True)
    names = []
    for (design, std), resp in runs.items():
        name = run_csv_name(design, std)
        text = csv_text(resp, None if full else CSV_MAX_ROWS)
        (Path(folder) / name).write_text(text, encoding="utf-8")  # the report's own folder
        names.append(name)
    return names


def _remove_own(folder: Path, name: str) -> None:
    """Delete ``folder/name`` only if the folder's marker records it with this content."""
    from .._output import _digest, _recorded

    sha = (_recorded(folder) or {}).get(name)
    target = folder / name
    if sha is not None and _digest(target) == sha:
        target.unlink()


_CSV_TIMEOUT = 900.0  # seconds: a 300 s main run's CSV takes about 3 s


class BackgroundCsv:
    """Write the runs' CSV files (:func:`write_runs_csv`) in a thread started when the
    ``simulate`` stage is done: the float formatting (seconds for the full job) runs while the
    C stage waits for its compilers. ``fl-design run`` passes :meth:`after` to
    :func:`~fl_design.app.run_job` and :meth:`result` to :func:`write_report`.

    Parameters
    ----------
    out : str or pathlib.Path
        The report's folder (already claimed: :func:`fl_design._output.claim_output_folder`).
    main : bool
        Also write the main run.
    full : bool, optional
        Every sample (no row cap).

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> import tempfile
    >>> from fl_design.app._report_csv import BackgroundCsv
    >>> w = BackgroundCsv(tempfile.mkdtemp(), main=False)  # a new, empty folder
    >>> job = run_job(load_config(None), quick=True, stages=("derive", "simulate"),
    ...               progress=False, after=w.after)
    >>> len(w.result()) == len(job.results["simulate"]["runs"])
    True
    """

    def __init__(self, out, *, main: bool, full: bool = False):
        self.out, self.main, self.full = out, main, full
        self.thread = self.names = self.error = None
        self.cpu = 0.0  # seconds of CPU the thread used

    def after(self, stage: str, job) -> None:
        """Start the thread when ``stage`` is ``simulate`` (a :func:`run_job` ``after`` hook).

        Examples
        --------
        >>> from fl_design.app._report_csv import BackgroundCsv
        >>> w = BackgroundCsv(".", main=False)
        >>> w.after("sweep", None); w.thread is None
        True
        """
        if stage != "simulate":
            return
        import threading

        def work():
            start, cpu = time.perf_counter(), time.thread_time()
            try:
                self.names = write_runs_csv(job, self.out, main=self.main, full=self.full)
            except BaseException as exc:  # noqa: BLE001 - re-raised in the main thread
                self.error = exc
            job.timings["report_csv"] = time.perf_counter() - start
            self.cpu = time.thread_time() - cpu  # also in the stages' process CPU times

        self.thread = threading.Thread(target=work, name="fl-design-csv", daemon=True)
        self.thread.start()

    def wait(self) -> None:
        """Wait for the thread (at most 900 s; errors stay for :meth:`result`).

        Examples
        --------
        >>> from fl_design.app._report_csv import BackgroundCsv
        >>> BackgroundCsv(".", main=False).wait()
        """
        if self.thread is not None:
            self.thread.join(timeout=_CSV_TIMEOUT)

    def result(self) -> list | None:
        """The files written (None: never started); the thread's error is raised here.

        Examples
        --------
        >>> from fl_design.app._report_csv import BackgroundCsv
        >>> BackgroundCsv(".", main=False).result() is None
        True
        """
        from ..errors import ComputationError

        if self.thread is None:
            return None
        self.wait()
        if self.thread.is_alive():
            raise ComputationError(f"writing the runs' CSV files into {str(self.out)!r} took "
                                   f"over {_CSV_TIMEOUT:.0f} s; is the folder on a slow disk?")
        if self.error is not None:
            raise self.error
        return self.names


__all__ = ["CSV_MAX_ROWS", "BackgroundCsv", "csv_rows", "csv_text", "run_csv_name",
           "write_runs_csv"]
