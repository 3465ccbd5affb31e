"""One compiled closed loop per loop structure, kept while the page's sliders move.

:func:`fl_design.simulate` builds a :class:`fl_design.sim.ClosedLoop` and asks for its runner
on every call: for a 20 s TRMS run that is about 60 ms of graph building and source hashing
around 20 ms of compiled loop. The design enters the compiled loop in two ways: its structure
(the gains, ``ki``, the limits, ``T``, the observer polynomial: baked into the C code) and its
parameter vector (:meth:`fl_design.Design.parameter_vector`: the discretized observer of
``eps`` and ``T``, and ``gamma``), an input of every run, which is how :func:`fl_design.sweep`
runs a whole grid on one compiled loop. :class:`LoopCache` does what ``simulate`` does, step
for step, with the loop and runner of the last few structures kept: moving eps, gamma, the
reference, the noise or the run length reuses them; a new structure (gains, T, limits) builds
and compiles its loop once (a few seconds the first time, then the kernel cache). The result is
the :class:`fl_design.Response` that ``simulate`` returns, bit for bit
(``tests/ui/test_model.py`` compares them).

Examples
--------
>>> import fl_design as fl
>>> from fl_design.ui._loops import LoopCache
>>> cache = LoopCache()
>>> d = fl.presets.pendulum_design()
>>> r = cache.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 2.0))
>>> bool((r.y == fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 2.0)).y).all())
True
"""

from __future__ import annotations

import dataclasses
import math
import multiprocessing
import threading
from collections import OrderedDict

import numpy as np

#: Loop structures kept (each holds a compiled runner).
MAX_LOOPS = 8
#: Longest run (samples) worth interpreting while its kernel compiles; longer ones compile
#: here (the interpreter takes about 25 us a sample: 40 000 samples, about 1 s).
MAX_INTERPRETED = 40_000


def structure_key(design, substeps: int) -> str:
    """What of ``design`` is baked into the compiled loop (everything but eps and gamma).

    Parameters
    ----------
    design : fl_design.Design
        All of it but eps and the size of gamma (gamma's sign stays) makes the key.
    substeps : int
        RK4 steps per sample.

    Returns
    -------
    str
        Equal for two designs when one compiled loop serves both (eps and gamma are its
        run-time parameters).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.ui._loops import structure_key
    >>> d = fl.presets.paper_design()
    >>> structure_key(d, 1) == structure_key(d.replace(eps=0.1, gamma=1e-3), 1)
    True
    """
    est = design.estimator.replace(eps=1.0)
    ctrl = design.controller.replace(gamma=math.copysign(1.0, design.controller.gamma))
    return repr((est, ctrl, int(substeps)))


def _compile_kernel(blob: bytes, substeps: int) -> None:  # pragma: no cover (child)
    """Child process: build and compile the loop's kernel (cached on disk for the parent)."""
    import pickle
    import warnings

    from ..sim._options import Kernel
    from ..sim.kernel._loop import ClosedLoop

    warnings.simplefilter("ignore")
    plant, design = pickle.loads(blob)  # our own parent's bytes, through a pipe
    ClosedLoop(plant, design, substeps=substeps).runner(kernel=Kernel())


class LoopCache:
    """Compiled loops per structure (module docstring); thread-safe.

    Also the noise gain of :func:`fl_design.analysis.noise_gain`, computed the same way (the
    loop linearized at its equilibrium by :class:`fl_design.sim._loop_jacobian.LoopLinearizer`,
    the Jacobians of the sample map in the noise, the discrete Lyapunov equation) with the
    linearizer and the Jacobians built once per structure, ``p`` and ``r`` symbolic: equal to
    ``noise_gain`` to round-off (``tests/ui/test_model.py``), a few milliseconds a call.

    Parameters
    ----------
    size : int, optional
        Structures kept (least recently used dropped).
    compile_aside : bool, optional
        A new structure runs at once in CasADi's interpreter (a 20 s TRMS run: about 0.5 s
        instead of about 2 s of C compilation) while a child process compiles its kernel into
        the kernel cache; the next run of that structure after the compilation uses it. Same
        results either way (the kernel's contract). Default False: compile here, as
        ``simulate`` does.
    """

    def __init__(self, size: int = MAX_LOOPS, *, compile_aside: bool = False) -> None:
        self.size, self.compile_aside = size, compile_aside
        self._loops: OrderedDict = OrderedDict()
        self._noise: OrderedDict = OrderedDict()
        self._compiling: dict = {}
        self._lock = threading.Lock()
        self._closed = False
        self.last_compiled = True
        self._memo = None  # (design, substeps, structure key) of the last design asked
        self._substeps: dict = {}  # (id(plant), T) -> (plant, RK4 steps per sample)

    def _compile(self, key, plant, design, substeps: int) -> None:
        """Compile a structure's kernel in a child process (into the kernel cache).

        One compilation at a time, the latest structure's: a slider dragged over many gains
        does not start a compiler per position (an unfinished one is ended; its structure
        stays interpreted and is compiled again if it is asked for again).
        """
        from .._pickle import dumps

        with self._lock:
            stale = [(k, p) for k, p in self._compiling.items() if p.is_alive()]
            for k, _ in stale:
                del self._compiling[k]
                self._loops.pop(k, None)  # its interpreted loop: rebuilt (and compiled) if asked
        for _, proc in stale:
            proc.terminate()
            proc.join(timeout=10)
        ctx = multiprocessing.get_context("spawn")
        proc = ctx.Process(target=_compile_kernel, args=(dumps((plant, design)), substeps),
                           daemon=True,
                           name="fl-design-ui-compile")
        proc.start()
        with self._lock:
            self._compiling[key] = proc

    def close(self) -> None:
        """End the compiling child processes (their kernels are not used then)."""
        with self._lock:
            self._closed = True
            procs, self._compiling = list(self._compiling.values()), {}
        for proc in procs:
            if proc.is_alive():
                proc.terminate()
            proc.join(timeout=10)

    def _key(self, design, substeps: int) -> str:
        """:func:`structure_key`, once per design object (a redraw asks twice: run and noise)."""
        memo = self._memo
        if memo is None or memo[0] is not design or memo[1] != substeps:
            memo = self._memo = (design, substeps, structure_key(design, substeps))
        return memo[2]

    def _kept(self, table: OrderedDict, key, make):
        with self._lock:
            entry = table.pop(key, None)
            if entry is None:
                entry = make()
            table[key] = entry
            while len(table) > self.size:
                table.popitem(last=False)
            return entry

    def noise_gain(self, plant, design, *, r: float) -> float:
        """As :func:`fl_design.analysis.noise_gain` (default substeps) at reference ``r``.

        Parameters
        ----------
        plant : fl_design.Plant
            The plant (the same object on every call).
        design : fl_design.Design
            The design.
        r : float
            Constant reference of the equilibrium.

        Returns
        -------
        float
            u rms per unit rms of white measurement noise; ``inf`` for a loop that is not
            Schur at its equilibrium.

        Raises
        ------
        ComputationError
            No equilibrium of the loop (as ``noise_gain``).
        """
        import casadi as ca

        from ..analysis._noise import stationary_std
        from ..sim._loop_jacobian import LoopLinearizer
        from ..sim.kernel._loop import ClosedLoop, resolve_substeps

        steps = self._substeps.get((id(plant), design.T), (None, None))
        if steps[0] is not plant:  # the plant's linearization, once per plant and T
            steps = (plant, resolve_substeps(plant, design.T, None))
            self._substeps[(id(plant), design.T)] = steps
        steps = steps[1]

        def make():
            loop = ClosedLoop(plant, design, substeps=steps)
            x, s, w = ca.SX.sym("x", loop.n), ca.SX.sym("s", loop.m), ca.SX.sym("w")
            rr, p = ca.SX.sym("r"), ca.SX.sym("p", loop.n_p)
            x_next, s_next, u = loop.sample(x, s, rr, w, 0.0, p)[:3]
            X, F = ca.vertcat(x, s), ca.vertcat(x_next, s_next)
            fun = ca.Function("fl_ui_noise", [X, w, rr, p], [
                ca.jacobian(F, X), ca.jacobian(F, w), ca.jacobian(u, X), ca.jacobian(u, w)])
            return LoopLinearizer(loop), fun

        lin_of, fun = self._kept(self._noise, (id(plant), self._key(design, steps)), make)
        p = design.parameter_vector()
        lin = lin_of(float(r), p)
        if not lin.spectral_radius < 1.0:
            return math.inf
        M, G, C, D = (np.asarray(a, dtype=float) for a in fun(
            np.concatenate([lin.x_eq, lin.s_eq]), 0.0, float(r), p))
        return stationary_std(M, G, C, D)

    def simulate(self, plant, design, scenario, *, classifier=None):
        """As :func:`fl_design.simulate` (RK4, compiled kernel, default options).

        Parameters
        ----------
        plant : fl_design.Plant
            The plant (the same object on every call: the key does not include it).
        design : fl_design.Design
            The design.
        scenario : fl_design.Scenario
            The scenario (a duration given).
        classifier : fl_design.Classifier, optional
            The classifier.

        Returns
        -------
        fl_design.Response
        """
        from .._limits import check_memory
        from ..sim._options import Kernel
        from ..sim._run import prepare_run
        from ..sim._simulate import _response

        run = prepare_run(plant, design, scenario, classifier=classifier)
        check_memory(8.0 * run.N * (run.loop.record_layout.size + 4),
                     f"recording a run of {run.N:.3g} samples",
                     "shorten the run length or sample slower (a larger T)")
        key = (id(plant), self._key(design, run.loop.substeps))
        compiled_aside = False
        with self._lock:
            entry = self._loops.get(key)
            job = self._compiling.get(key)
            if entry is not None and not entry[2] and job is not None and not job.is_alive():
                entry = None  # compiled meanwhile (or failed: then compiled here, as simulate)
                compiled_aside = True
                self._compiling.pop(key)
                self._loops.pop(key)
        if entry is None:
            if self.compile_aside and not compiled_aside and key not in self._compiling \
                    and not self._closed and run.N <= MAX_INTERPRETED:
                entry = (run.loop, run.loop.runner(kernel=Kernel(compiled=False)), False)
                self._compile(key, plant, design, run.loop.substeps)
            else:
                entry = (run.loop, run.loop.runner(kernel=Kernel()), True)
        loop, runner, compiled = self._kept(self._loops, key, lambda: entry)
        self.last_compiled = compiled
        run = dataclasses.replace(run, loop=loop)
        p = design.parameter_vector()
        acc, out = runner.record(run.initial_accumulator(p)[:, 0], run.D)
        summary = {k: np.asarray(v).copy() for k, v in loop.layout.unpack(acc).items()}
        summary["solver_failed"] = 0.0
        return _response(run, out, summary, "rk4")


__all__ = ["MAX_INTERPRETED", "LoopCache", "structure_key"]
