"""The main job (``fl-design run``): a pipeline of stages over objects built once.

:func:`prepare` turns the config into a :class:`~fl_design.app._build.Setup` (plant, design,
scenario, classifier, compared designs) once; :func:`run_job` runs the stages of
:mod:`fl_design.app._stages` and :mod:`fl_design.app._stage_family` in order, each a function
of the setup and of earlier stages' results, and collects their results in a :class:`Job`.
The report modules read a finished job; none of them imports this module. Progress goes to
stderr, one line per step (and the sweep's bar), never into the tables on stdout.

Examples
--------
>>> from fl_design.app import load_config, run_job
>>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
>>> job.derivation["rho"], job.timings["derive"] >= 0
(2, True)
"""

from __future__ import annotations

import pickle
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import _stage_family as family
from . import _stages
from ._beside import TARGETS, Beside, certify_stage
from ._brief import lost_line
from ._build import build_setup
from ._config import Config
from ._stage_cache import cached_stage
from ._stages import QUICK, STAGES, noise_levels


@dataclass
class Job:
    """Everything the main job computed (filled stage by stage).

    Parameters
    ----------
    config : Config
        The validated configuration.
    quick : bool
        Short runs (tests).
    plant : fl_design.Plant
        The plant (set by :func:`prepare`).
    design : fl_design.Design
        The design (set by :func:`prepare`).
    derivation : dict
        Relative degree, ``a``, ``b``, b-range, zero dynamics, ``F^a``, residual orders.
    results : dict
        Stage name -> its results (certificates, StabilityMap, Responses, C package).
    timings : dict
        Stage name -> seconds.
    cached : set
        The stages whose results were read from the private cache (derive, certify:
        :mod:`fl_design.app._stage_cache`).
    setup : fl_design.app._build.Setup
        The config's objects (set by :func:`prepare`).
    lost : dict
        Stage name -> one line saying how many of its runs were lost and which worker died
        (a worker of the executor died mid-sweep: the stage's result is the partial one,
        :func:`fl_design.app._brief.lost_line`). Empty for a complete job; the report and
        ``fl-design run``'s exit code (3) say a job with lost runs is partial.

    Examples
    --------
    >>> from fl_design.app import Job, load_config
    >>> Job(load_config(None), quick=True).results
    {}
    """

    config: Config
    quick: bool = False
    plant: object = None
    design: object = None
    derivation: dict = field(default_factory=dict)
    results: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    cached: set = field(default_factory=set)
    setup: object = None
    lost: dict = field(default_factory=dict)

    @property
    def partial(self) -> bool:
        """True when some stage lost runs to a dead worker (:attr:`lost`)."""
        return bool(self.lost)


def note(message: str, *, enabled: bool = True) -> None:
    """Write one progress line to stderr (never to stdout, where the tables go).

    Parameters
    ----------
    message : str
        The line.
    enabled : bool, optional
        False: say nothing.

    Examples
    --------
    >>> from fl_design.app._job import note
    >>> note("sweeping", enabled=False)
    """
    if enabled:
        print(f"[fl-design] {message}", file=sys.stderr, flush=True)


def prepare(config: Config) -> Job:
    """Build the config's objects once and check they fit (cheap; before any work).

    Parameters
    ----------
    config : Config
        A validated configuration.

    Returns
    -------
    Job
        With ``setup``, ``plant`` and ``design`` set.

    Raises
    ------
    DesignMismatchError
        The design's relative degree (its number of gains) differs from the plant's.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._job import prepare
    >>> prepare(load_config(None)).design.controller.gamma
    0.0003
    """
    setup = build_setup(config)
    return Job(config, plant=setup.plant, design=setup.design, setup=setup)


def _cached(job: Job, name: str, quick: bool, compute):
    results, hit = cached_stage(job.setup, name, quick, compute)
    if hit:
        job.cached.add(name)
    return results


def _steps(job: Job, quick: bool, out_dir: Path, executor, progress: bool, force: bool,
           package_dir=None):
    """Stage name -> a callable storing that stage's results in ``job``."""
    s = job.setup

    def derive():
        job.derivation = _cached(job, "derive", False, lambda: _stages.derive(s))

    def certify():  # the function the child process runs (certify_stage), run here
        job.results["certify"], hit = certify_stage(
            s, job.derivation, quick, progress=lambda line: note(line, enabled=progress))
        if hit:
            job.cached.add("certify")

    def sweep():
        smap = job.results["sweep"] = _stages.sweep(s, quick, executor, progress)
        line = lost_line(smap)
        if line:  # a worker died: the partial map is kept (never cached), the job goes on
            job.lost["sweep"] = line
            note(f"sweep: {line}; the later stages do not read the map's points, the report "
                 "is marked partial", enabled=True)

    def simulate():
        job.results["simulate"] = _stages.simulate(s, quick)

    def robustness():
        out = family.robustness(s, quick, executor, progress)
        for key, what in (("robustness", "ensemble"), ("robust_map", "robust map")):
            line = lost_line(out.get(key), what)
            if line:  # as the sweep: the partial result kept, the report marked partial
                job.lost[key] = line
                note(f"robustness: {line}; the report is marked partial", enabled=True)
        if "robust_map_seconds" in out:
            job.timings["robust_map"] = out.pop("robust_map_seconds")
        job.results.update(out)

    def codegen():
        job.results["codegen"] = _stages.codegen(s, quick, out_dir, force,
                                                   package_dir=package_dir)

    return {"derive": derive, "certify": certify, "sweep": sweep, "simulate": simulate,
            "robustness": robustness, "codegen": codegen}


def run_job(config: Config, *, quick: bool = False, out_dir: str | Path = "out",
            stages=STAGES, executor=None, progress: bool = True, force: bool = False,
            after=None, package_dir=None) -> Job:
    """Run the main job's stages (derive, certify, sweep, simulate, robustness, codegen).

    ``robustness`` (:func:`fl_design.monte_carlo` over the ``[uncertainty]`` family) runs only
    when the config gives ``[uncertainty] params``. The stages of :data:`BESIDE` (certify) run
    in a child process beside the later stages when any follow (the same results, the two
    cores used; a process because CasADi is not thread safe); the job waits for them before it
    returns, re-raises their errors, and kills them when it stops early.

    Parameters
    ----------
    config : Config
        A validated configuration (:func:`load_config`).
    quick : bool, optional
        Short runs and small grids (seconds; for tests).
    out_dir : str or pathlib.Path, optional
        Where the C package goes (``out_dir/c``).
    stages : sequence of str, optional
        A subset of :data:`STAGES`, run in the canonical order.
    executor : concurrent.futures.Executor, optional
        Runs the sweep's chunks (e.g. a Dask cluster's ``client.get_executor()``).
    progress : bool, optional
        Progress lines and the sweep's bar on stderr.
    force : bool, optional
        Write the C package into ``out_dir/c`` even if it holds files fl_design did not write.
    after : callable, optional
        Called as ``after(stage, job)`` when each stage is done (``fl-design run`` starts
        writing the runs' CSV files after ``simulate``, while the C compilers run).
    package_dir : str or pathlib.Path, optional
        Where the C package goes instead of ``out_dir/c`` (``fl-design codegen --verify``: the
        folder given by ``--out``, as without ``--verify``).

    Returns
    -------
    Job

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> [round(b, 9) for b in job.derivation["b_bounds"]]
    [3.6, 6.8]
    """
    job = prepare(config)
    job.quick = quick
    steps = _steps(job, quick, Path(out_dir), executor, progress, force, package_dir)
    todo = [s for s in STAGES if s in stages or (s == "derive" and "certify" in stages)]
    if not config.uncertainty.params:  # robustness only with [uncertainty] params
        todo = [s for s in todo if s != "robustness"]
    label = {stage: f"{i}/{len(todo)}" for i, stage in enumerate(todo, 1)}
    starts = _beside_starts(todo)
    early = {name: _spawn_beside(job, name, quick, progress) for name in starts.values()}
    running, joined = [], []
    try:
        for k, stage in enumerate(todo):
            if k in starts:  # a stage of BESIDE starts in its process before this one
                name = starts[k]
                b = _start_beside(job, early.pop(name), name, label[name], quick, progress,
                                  steps[name])
                if b is not None:
                    running.append(b)
                elif after is not None:
                    after(name, job)
            if stage in starts.values():
                continue
            _run_stage(job, stage, label[stage], steps[stage], progress)
            for b in running:
                b.raise_error()  # it failed: stop here, as it would have run alone
            for b in [b for b in running if b.done()]:  # it answered: its results in now
                running.remove(b)
                joined.append(b)
                _join_beside(job, b, progress)
                if after is not None:
                    after(b.stage, job)
            if after is not None:
                after(stage, job)
        for b in running:
            _join_beside(job, b, progress)
            if after is not None:
                after(b.stage, job)
    finally:
        for b in [*running, *joined, *early.values()]:
            if b is not None:
                b.close()  # an error or Ctrl-C in the main stages: no orphan child left
    return job


#: Stages run in a child process beside the later ones, and the stage after which each starts:
#: the certificates (NumPy, CVXPY/Clarabel: one core) start once derive is done (they need its
#: b-range), beside the sweep, simulate and codegen. On 2 cores the certify stage's CPU is the
#: job's critical path: started after the sweep (as until session 33) it ended ~2 s after the
#: other stages on the TRMS; beside the sweep it costs the sweep's two threads a share of a core
#: for about a second and ends with the others (every stage's results are unchanged). A
#: process, not a thread: CasADi is not thread safe (:mod:`fl_design.app._beside`).
BESIDE = {"certify": "derive"}


def _beside_starts(todo) -> dict:
    """``{position in todo: stage of BESIDE started in its thread just before it}``.

    A stage of :data:`BESIDE` starts after the stage it names (or at its own place when that
    one is not run) and only when some stage is left to run beside it; otherwise it runs in
    turn.

    Examples
    --------
    >>> from fl_design.app._job import _beside_starts
    >>> _beside_starts(["derive", "certify", "sweep", "simulate", "codegen"])
    {2: 'certify'}
    >>> _beside_starts(["derive", "certify", "sweep"]), _beside_starts(["derive", "certify"])
    ({2: 'certify'}, {})
    """
    out = {}
    for k, stage in enumerate(todo):
        if stage not in BESIDE:
            continue
        first = todo.index(BESIDE[stage], k) if BESIDE[stage] in todo[k:] else k
        if first + 1 < len(todo):
            out[first + 1] = stage
    return out


def _run_stage(job: Job, stage: str, label: str, step, progress: bool) -> None:
    """Run one stage in this thread, timed (wall and this process's CPU)."""
    note(f"{label} {stage} ...", enabled=progress)
    start, cpu = time.perf_counter(), time.process_time()
    step()
    job.timings[stage] = time.perf_counter() - start
    # this process's CPU time beside the wall time: on a loaded machine they differ
    how = " from the cache" if stage in job.cached else ""
    note(f"{label} {stage} done in {job.timings[stage]:.1f} s (CPU "
         f"{time.process_time() - cpu:.1f} s{how})", enabled=progress)


def _spawn_beside(job: Job, stage: str, quick: bool, progress: bool):
    """A child process for ``stage`` started now (its imports overlap the earlier stages).

    None when the stage's results are cached (read here, stored in ``job``: no process for a
    lookup) or when no process can be started (the stage then runs in turn).
    """
    from ._stage_cache import cached_results

    results = cached_results(job.setup, stage, quick)
    if results is not None:
        job.results[stage] = results
        job.cached.add(stage)
        return None
    try:
        return Beside(stage, "", say=(lambda line: note(line)) if progress else None)
    except OSError as err:
        note(f"{stage}: runs in turn (no child process: {err})", enabled=progress)
        return None


def _start_beside(job: Job, b, stage: str, label: str, quick: bool, progress: bool, step):
    """Send ``stage`` to its child process ``b``, or run it now (no child, not sendable), or
    only say it is done (its cached results were read by :func:`_spawn_beside`).

    Returns the running :class:`~fl_design.app._beside.Beside`, or None when the stage is
    done.
    """
    if b is not None:
        b.label = label
        try:
            b.submit(TARGETS[stage], (job.setup, job.derivation, quick))
        except (pickle.PicklingError, TypeError, AttributeError, OSError) as err:
            note(f"{label} {stage}: runs in turn (no child process: {err})", enabled=progress)
        else:
            note(f"{label} {stage} ... (in a process beside the next stages)", enabled=progress)
            return b
    _run_stage(job, stage, label, (lambda: None) if stage in job.results else step, progress)
    return None


def _join_beside(job: Job, b: Beside, progress: bool) -> None:
    """Wait for a stage run beside the others, store its results and time, re-raise."""
    start = time.perf_counter()
    results, hit = b.wait()
    job.results[b.stage] = results
    if hit:
        job.cached.add(b.stage)
    job.timings[b.stage] = b.wall
    how = " from the cache" if hit else ""
    note(f"{b.label} {b.stage} done in {b.wall:.1f} s (CPU {b.cpu:.1f} s{how}; in a process "
         f"beside the other stages, {time.perf_counter() - start:.1f} s waited after them)",
         enabled=progress)


__all__ = ["BESIDE", "QUICK", "STAGES", "Job", "noise_levels", "note", "prepare", "run_job"]
