"""The adaptive stability map: the points ``undecided`` at the map's duration are re-run longer.

A sweep runs every grid point for one duration ``D`` (given, or chosen once at the design
point: :mod:`fl_design.sim._duration`). Where the map's gains make a loop much slower than the
design's, that one length is too short: the TRMS's smallest gains swing with periods of
170-230 s while a 300 s run gives the classifier a 150 s window, and those runs are
``undecided`` (bounded, a trend the window cannot call). A control engineer would look at a
longer record of those runs only; so does :func:`fl_design.sweep` (``extend``, default
:data:`EXTEND` = 2 for an adaptive duration): the undecided points are re-run ``extend * D``,
again ``extend`` times longer while some stay undecided, up to ``max_duration`` (default
``max(extend, MAX_EXTENSION) * D`` = 4 D: at most two doublings). Each re-run is classified on
its own tail window, exactly as a run of that length would be (the same kernel and
accumulators), and its length is kept (:attr:`StabilityMap.durations`). What stays undecided
at the cap is ambiguous evidence at that length, said as such.

Why doubling: it doubles the analysis window (the run's second half) at the least cost, and
repeating it stops at the first length that decides (the demo map's 37 undecided runs at
300 s are all decided at 600 s, a window of 1.3-1.8 of their swings; x4 at once would cost
twice as much for the same verdicts). The cap bounds the cost: a point undecided at every
length costs ``2 D + 4 D`` on top of its first run. Why not track swings longer than the
window in the accumulators instead: a swing half as long as the run shows at most one
reversal in the run's second half whatever is accumulated, and the classifier's decisions
(decay, sustained swing) need several; a longer record is the evidence that decides, and its
cost is paid only where the short one was not enough.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim._adaptive import extension_options
>>> extension_options(fl.Scenario(0.1), None, None), extension_options(fl.Scenario(0.1, 5.0), None, None)
((2.0, None), (1.0, None))
"""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as V
from ..errors import ParameterError
from ._disturbance import summary_metrics
from ._grid import run_grid
from ._metrics import metrics_from_summary
from ._run import RunSetup
from ._status import Status

#: Runs finalized at once: every run's metrics depend on its own accumulators only, so a
#: grid is finalized in blocks and the temporaries of the classification do not grow with it
#: (the memory of a map stays its accumulators and its metrics).
ASSEMBLE_CHUNK = 512


def _finalize(run: RunSetup, acc: np.ndarray) -> dict:
    """Status codes and metrics (flat) of the runs of ``acc``."""
    info = run.loop.layout.unpack(acc)
    info["est2_sum"] = np.asarray(info["est2_sum"]).T
    m = metrics_from_summary(info, run.T, run.metrics)
    if math.isfinite(run.disturbance_start):  # the response to the scenario's disturbance
        dist = summary_metrics(info, run.T, run.disturbance_start)
        m.update({k: v for k, v in dist.items() if run.metrics is None or k in run.metrics})
    return {k: np.asarray(v).reshape(acc.shape[1], *np.shape(v)[1:]) if np.ndim(v) else
            np.full(acc.shape[1], v) for k, v in m.items()}


def assemble(run: RunSetup, acc: np.ndarray, shape: tuple) -> tuple[np.ndarray, dict]:
    """Status codes and metrics, shaped ``shape``, from the final accumulators of the runs.

    Parameters
    ----------
    run : RunSetup
        The runs' samples and constants.
    acc : numpy.ndarray
        ``(nacc, n)`` final accumulators (:func:`fl_design.sim._grid.run_grid`).
    shape : tuple
        Shape of the ``n`` runs (``(n_e, n_g)`` for a map).

    Returns
    -------
    (numpy.ndarray, dict)
        Status codes and ``{metric: array of shape shape}`` (``estimation_rms``: one more
        axis).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._adaptive import assemble
    >>> from fl_design.sim._grid import parameter_columns, run_grid
    >>> from fl_design.sim._run import prepare_run
    >>> d = fl.presets.pendulum_design()
    >>> run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 6.0))
    >>> acc = run_grid(run, parameter_columns(d, [0.02, 0.2], [1e-2]),
    ...                kernel=fl.Kernel(compiled=False), progress=False)
    >>> status, metrics = assemble(run, acc, (2, 1))
    >>> status.tolist(), metrics["estimation_rms"].shape
    ([[1], [-1]], (2, 1, 3))
    """
    acc = np.asarray(acc, dtype=float).reshape(run.loop.layout.size, -1)
    parts = Assembly(run, acc.shape[1])
    parts(0, acc.shape[1], acc)
    return parts.result(shape)


class Assembly:
    """:func:`assemble` range by range: ``finish`` of :func:`~fl_design.sim._grid.run_grid`.

    Each call finalizes the runs ``a:b`` (in blocks of :data:`ASSEMBLE_CHUNK`, filled in
    place); :meth:`result` shapes them once every run is in. The same blocks give the same
    bits whichever ranges the grid is cut into (every run's metrics are computed from its
    own accumulators, elementwise or along its own axis).

    Parameters
    ----------
    run : RunSetup
        The runs' samples and constants.
    n : int
        Number of runs.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._adaptive import Assembly, assemble
    >>> from fl_design.sim._grid import parameter_columns, run_grid
    >>> from fl_design.sim._run import prepare_run
    >>> d = fl.presets.pendulum_design()
    >>> run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 6.0))
    >>> parts = Assembly(run, 2)
    >>> acc = run_grid(run, parameter_columns(d, [0.02, 0.2], [1e-2]), finish=parts,
    ...                kernel=fl.Kernel(compiled=False), progress=False)
    >>> parts.result((2, 1))[0].tolist(), assemble(run, acc, (2, 1))[0].tolist()
    ([[1], [-1]], [[1], [-1]])
    """

    def __init__(self, run: RunSetup, n: int):
        self.run, self.n, self.values = run, int(n), {}

    def __call__(self, a: int, b: int, acc: np.ndarray) -> None:
        """Finalize runs ``a:b`` from their final accumulators ``acc`` (``(nacc, b - a)``)."""
        for c in range(a, max(b, a + 1), ASSEMBLE_CHUNK):
            part = _finalize(self.run, acc[:, c - a:c - a + ASSEMBLE_CHUNK])
            for k, v in part.items():
                if k not in self.values:
                    self.values[k] = np.empty((self.n, *v.shape[1:]), dtype=v.dtype)
                self.values[k][c:c + v.shape[0]] = v

    def result(self, shape: tuple) -> tuple[np.ndarray, dict]:
        """Status codes and metrics shaped ``shape``, as :func:`assemble` returns them."""
        m = dict(self.values)
        status = m.pop("status").reshape(shape)
        metrics = {k: (v.reshape(*shape, -1) if k == "estimation_rms" else v.reshape(shape))
                   for k, v in m.items()}
        return status, metrics


#: Default factor of the re-runs of an adaptive map's undecided points (a doubling).
EXTEND = 2.0
#: Default longest re-run, in map durations ``D`` (or ``extend``, when larger).
MAX_EXTENSION = 4.0


def extension_options(scenario, extend, max_duration) -> tuple[float, float | None]:
    """Validated ``(extend, max_duration)`` of :func:`fl_design.sweep`.

    Parameters
    ----------
    scenario : Scenario
        The sweep's scenario (validated): ``duration`` None is the adaptive length.
    extend : float or None
        Factor >= 1 of the re-runs; None: :data:`EXTEND` for an adaptive duration or when
        ``max_duration`` is given, else 1 (no re-run: a given duration is kept).
    max_duration : float or None
        Longest re-run (s, > 0), or None (``max(extend, MAX_EXTENSION)`` times the map's
        duration).

    Returns
    -------
    (float, float or None)

    Raises
    ------
    ParameterError
        ``extend`` not a real number >= 1, ``max_duration`` not > 0, or given with
        ``extend=1`` (no re-run to bound).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._adaptive import extension_options
    >>> extension_options(fl.Scenario(0.1, 5.0), 2, 60.0)
    (2.0, 60.0)
    >>> extension_options(fl.Scenario(0.1, 5.0), None, 60.0)  # a cap asks for re-runs
    (2.0, 60.0)
    """
    if extend is None:
        extend = EXTEND if scenario.duration is None or max_duration is not None else 1.0
    extend = V.real_scalar("extend", extend)
    if not extend >= 1.0:
        raise ParameterError(f"extend must be >= 1 (the factor by which undecided runs are "
                             f"re-run longer; 1: none), got {extend!r}")
    if max_duration is not None:
        max_duration = V.positive("max_duration", max_duration)
        if extend == 1.0:
            raise ParameterError(f"max_duration={max_duration!r} bounds the re-runs of "
                                 "undecided points, but extend=1 makes none; give extend > 1 "
                                 "or leave max_duration out")
    return extend, max_duration


def longest_rerun(run: RunSetup, extend: float, max_duration: float | None) -> float:
    """The longest re-run (s): ``max_duration`` (default ``max(extend, MAX_EXTENSION) * D``),
    within the per-run sample limit (:func:`fl_design.sim._scenario.max_samples`).

    Parameters
    ----------
    run : RunSetup
        The map's runs (``run.duration`` is ``D``).
    extend : float
        Factor of the re-runs.
    max_duration : float or None
        As given to :func:`fl_design.sweep`.

    Returns
    -------
    float

    Raises
    ------
    ParameterError
        ``max_duration`` not longer than the map's duration ``D`` (nothing to re-run).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._adaptive import longest_rerun
    >>> from fl_design.sim._run import prepare_run
    >>> run = prepare_run(fl.plants.pendulum(), fl.presets.pendulum_design(),
    ...                   fl.Scenario(0.05, 10.0))
    >>> longest_rerun(run, 2.0, None), longest_rerun(run, 8.0, None), longest_rerun(run, 2.0, 25.0)
    (40.0, 80.0, 25.0)
    """
    from ._scenario import max_samples

    if max_duration is not None and max_duration <= run.duration * (1 + 1e-9):
        raise ParameterError(f"max_duration={max_duration!r} s must exceed the map's duration "
                             f"{run.duration:g} s (the re-runs are longer); give a larger one")

    wanted = (max(extend, MAX_EXTENSION) * run.duration if max_duration is None
              else max_duration)
    return min(wanted, max_samples() * run.T)


def rerun_undecided(run, columns, status, metrics, durations, extend, cap, prepare, *,
                    kernel, executor, progress, acc=None) -> None:
    """Re-run the ``undecided`` points ``extend`` times longer, again while some stay
    undecided, up to ``cap`` seconds; write their status, metrics and length in place.

    Why re-run rather than judge the short run harder: an ``undecided`` run is bounded and
    its envelope's trend cannot be called over the analysis window (the run's second half),
    typically a loop whose slowest mode (a swing of period 170-230 s at the TRMS's smallest
    gains) is slower than the window the map's one duration gives it. A control engineer
    would look at a longer record; ``extend`` times the length gives the window ``extend``
    times the swings, at the cost of those points only. Each re-run is classified on its own
    tail window, as a run of that length would be; what stays undecided at ``cap`` is
    ambiguous evidence at that length (:meth:`StabilityMap.extension_text` says so: a longer
    ``max_duration`` decides).

    Parameters
    ----------
    run : RunSetup
        The map's runs, of length ``D``.
    columns : fl_design.sim._grid._Columns
        The grid's parameter columns (``take(idx)``).
    status, metrics, durations : numpy.ndarray, dict
        The map's status codes, metrics and run lengths, written in place.
    extend, cap : float
        Factor of each re-run, longest re-run (s).
    prepare : callable
        ``prepare(scenario) -> RunSetup``: the runs under a longer scenario.
    kernel, executor, progress
        As for :func:`fl_design.sweep`.
    acc : numpy.ndarray, optional
        ``(nacc, n_e * n_g)`` final accumulators of the map's runs: in this process (no
        ``executor``) a re-run then continues its shorter run (:func:`continue_runs`) instead
        of starting again, with the same result.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._adaptive import rerun_undecided
    >>> from fl_design.sim._grid import _Columns
    >>> from fl_design.sim._run import prepare_run
    >>> plant, d = fl.plants.pendulum(), fl.presets.pendulum_design(u_limits=(-2.0, 2.0))
    >>> smap = fl.sweep(plant, d, fl.Scenario(0.1, 17.549), eps=[0.5], gamma=[1e-3],
    ...                 progress=False)
    >>> smap.labels.tolist()  # a swing slower than the window
    [['undecided']]
    >>> status, metrics, durations = smap.status.copy(), dict(smap.metrics), smap.durations.copy()
    >>> prepare = lambda scenario: prepare_run(plant, d, scenario)
    >>> rerun_undecided(prepare(fl.Scenario(0.1, 17.549)), _Columns(d, [0.5], [1e-3]), status,
    ...                 metrics, durations, 4.0, 4 * 17.549, prepare, kernel=None,
    ...                 executor=None, progress=False)
    >>> status.tolist(), durations.tolist()
    ([[0]], [[70.196]])
    """
    todo = np.flatnonzero(status == int(Status.UNDECIDED))
    length = run.duration
    last = None if acc is None or executor is not None else acc[:, todo]
    while todo.size and length < cap * (1 - 1e-9):
        length = min(length * extend, cap)
        longer = prepare(run.scenario.replace(duration=length))
        desc = f"re-run {todo.size} undecided at {length:g} s"
        done = (None if last is None else
                continue_runs(run, longer, last, kernel=kernel, progress=progress, desc=desc))
        if done is None:  # start again from the first sample
            done = run_grid(longer, columns.take(todo), kernel=kernel, executor=executor,
                            progress=progress, desc=desc)
        s, m = assemble(longer, done, (todo.size,))
        run, last = longer, (None if executor is not None else done[:, s == int(Status.UNDECIDED)])
        at = np.unravel_index(todo, status.shape)
        status[at] = s
        for k, v in m.items():
            metrics[k][at] = v
        durations[at] = longer.duration
        todo = todo[s == int(Status.UNDECIDED)]


def continue_runs(run, longer, acc, *, kernel=None, progress=False,
                  desc="continue") -> np.ndarray | None:
    """The final accumulators of ``longer``, continuing the finished runs ``acc`` of ``run``.

    A run's state and its whole-run accumulators (:data:`~fl_design.sim._metrics.WHOLE_RUN`:
    extremes, sums, first times) do not depend on its length; the others are gated by the
    tail and the analysis window, which a run at least twice as long starts no earlier than
    the shorter run's end. So the longer run equals the shorter one continued: the state and
    whole-run values kept, the windowed ones restarted, the longer run's constants set, and
    only its remaining samples run (a doubling costs one more ``D``, not two). The result is
    the same as a run from the first sample (same kernel, same arithmetic in the same order:
    ``tests/sim/test_sweep_adaptive.py`` checks equality to the last bit).

    Parameters
    ----------
    run, longer : RunSetup
        The finished runs' setup and the longer one.
    acc : numpy.ndarray
        ``(nacc, m)`` final accumulators of ``run``.
    kernel : Kernel, optional
        As for :func:`fl_design.sweep` (runs in this process).
    progress : bool, optional
        Progress bar.
    desc : str, optional
        Its label.

    Returns
    -------
    numpy.ndarray or None
        ``(nacc, m)``; None when ``longer`` cannot continue ``run``: its window or tail starts
        before ``run``'s end, its first samples or its constants differ (a time-varying
        reference whose step changes with the length).

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> from fl_design.sim._adaptive import continue_runs
    >>> from fl_design.sim._grid import parameter_columns, run_grid
    >>> from fl_design.sim._run import prepare_run
    >>> plant, d = fl.plants.pendulum(), fl.presets.pendulum_design()
    >>> short, long = (prepare_run(plant, d, fl.Scenario(0.05, t)) for t in (5.0, 10.0))
    >>> P = parameter_columns(d, [0.02, 0.05], [1e-2])
    >>> acc = continue_runs(short, long, run_grid(short, P, progress=False))
    >>> np.array_equal(acc, run_grid(long, P, progress=False))
    True
    >>> continue_runs(long, short, acc) is None  # not longer
    True
    """
    from ._grid import _cores, _Progress, _runner, block_length
    from ._metrics import ACCUMULATORS, RUN_CONSTANTS, WHOLE_RUN
    from ._options import Kernel, option

    start = run.N
    window = (2 * longer.k_mid - longer.k_tail) // 2  # the kernel's window start
    same = ("y0", "step", "tol", "noise", "k_dist")
    if (min(window, longer.k_tail) < start
            or any(run.constants()[c] != longer.constants()[c] for c in same)
            or run.q != longer.q or not np.array_equal(longer.D[:, :start], run.D)):
        return None
    lay = longer.loop.layout
    restart = {a.name for a in ACCUMULATORS} - set(WHOLE_RUN) | set(RUN_CONSTANTS)
    out = longer.initial_accumulator(lay.unpack(acc)["p"])
    for name, _ in lay.fields:
        if name not in restart:
            out[lay[name]] = acc[lay[name]]
    kernel = option("kernel", kernel, Kernel)
    threads = kernel.threads if kernel.threads is not None else _cores()
    runner = _runner(longer, kernel)
    block = block_length(out.shape[1], threads, kernel.compiled)
    bar = _Progress(out.shape[1], bool(progress), desc)
    try:
        for a in range(start, longer.N, block):
            out = runner.run(out, longer.D[:, a:a + block], threads=threads)
        bar.update(out.shape[1])
    finally:
        bar.close()
    return out


def run_points(run, columns, idx, *, kernel, executor, progress, desc):
    """Status and metrics of the grid points ``idx`` (flat indices) under ``run``.

    Parameters
    ----------
    run : RunSetup
        Samples and constants of the runs.
    columns : fl_design.sim._grid._Columns
        The grid's parameter columns.
    idx : numpy.ndarray
        Flat (row-major) indices of the points.
    kernel, executor, progress
        As for :func:`fl_design.sweep`.
    desc : str
        Label of the progress bar.

    Returns
    -------
    (numpy.ndarray, dict)
        As :func:`assemble`, of shape ``(idx.size,)``.

    Examples
    --------
    >>> from fl_design.sim._adaptive import run_points
    >>> from fl_design.sim._grid import _Columns
    >>> from fl_design.sim._run import prepare_run
    >>> d = fl.presets.pendulum_design()
    >>> run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 6.0))
    >>> status, _ = run_points(run, _Columns(d, [0.02, 0.2], [1e-2]), np.array([1]),
    ...                        kernel=fl.Kernel(compiled=False), executor=None,
    ...                        progress=False, desc="points")
    >>> status.tolist()
    [-1]
    """
    acc = run_grid(run, columns.take(idx), kernel=kernel, executor=executor,
                   progress=progress, desc=desc)
    return assemble(run, acc, (idx.size,))


__all__ = ["EXTEND", "MAX_EXTENSION", "Assembly", "assemble", "continue_runs", "extension_options", "longest_rerun", "rerun_undecided",
           "run_points"]
