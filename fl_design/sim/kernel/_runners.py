"""Run the closed-loop step over time and parameter columns: compiled C, or CasADi's interpreter.

The accumulating step ``fl_acc(acc, d) -> acc_next`` and the recording step ``fl_rec(acc, d) ->
(acc_next, out)`` of :class:`fl_design.sim.ClosedLoop` are CasADi functions. Two runners
evaluate them over ``nsteps`` samples and many accumulator columns (one per grid point), with
the same interface and the same results:

* :class:`~fl_design.sim.kernel._lanes.LanesRunner` (default, :func:`make_runner`): grids run on W grid
  points per SIMD vector (:mod:`fl_design.sim.kernel._lanes`); a recorded run goes to
* :class:`NativeRunner`: CasADi generates the C code of the recording step (the
  accumulating one is the same step without its output); the driver
  template ``templates/kernel_driver.c.in`` appended to it loops over columns and samples
  (double-buffered accumulators, no copies) and stops a column as soon as it has diverged
  (the remaining samples of a frozen run only advance its counter ``k``, which the driver adds
  at once). The source is compiled and cached by :func:`fl_design._toolchain.build` and called
  through ``ctypes``, which releases the GIL: small pieces of the columns are taken in turn
  by the threads (kept for the runner's life, :class:`ThreadsOwner`).
* :class:`InterpretedRunner`: the same steps folded with CasADi (``fold``/``mapaccum`` over
  blocks of samples, padded samples are no-ops) in CasADi's virtual machine. Used, with a
  :class:`~fl_design.errors.CompilationWarning` (never silently), when no C compiler works, or
  on request.

Why a C driver rather than compiling CasADi's own ``fold``/``map``: CasADi unrolls ``fold`` as
a tower of ``mapaccum`` levels that store and copy every intermediate accumulator; measured on
the TRMS loop this costs 1.4-2x the plain C loop, against about 1.1x for the driver (see
``verify/bench_sweep.py``).

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim import ClosedLoop
>>> loop = ClosedLoop(fl.plants.pendulum(), fl.presets.pendulum_design(), substeps=1)
>>> runner = loop.runner(compiled=False)
>>> type(runner).__name__, runner.nacc == loop.layout.size
('InterpretedRunner', True)
"""

from __future__ import annotations

import ctypes
import functools
import itertools
import math
import warnings
from importlib import resources

import casadi as ca
import numpy as np

from ..._limits import env_flag
from ..._toolchain import (
    UnverifiedLibrary,
    build,
    discard,
    find_compiler,
    generate_source,
    open_verified,
)
from ...errors import CompilationWarning, ComputationError, ParameterError
from ._emit import fill_template
from ._threads import ThreadsOwner, check_rows

#: Pieces per thread of a grid run by the scalar compiled kernel (taken in turn).
_PIECES = 8


@functools.lru_cache(maxsize=32)
def _load(path: str) -> ctypes.CDLL:
    lib = open_verified(path)
    dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    lib.fl_run.argtypes = [dbl, ctypes.c_long, dbl, ctypes.c_long]
    lib.fl_run.restype = ctypes.c_int
    lib.fl_record.argtypes = [dbl, dbl, ctypes.c_long, dbl]
    lib.fl_record.restype = ctypes.c_int
    return lib

class NativeRunner(ThreadsOwner):
    """Compiled runner: :meth:`run` folds ``fl_acc`` over samples for many columns.

    Parameters
    ----------
    accumulate, record : casadi.Function
        ``fl_acc(acc, d) -> acc_next`` and ``fl_rec(acc, d) -> (acc_next, out)``.
    indices : dict
        Accumulator positions of ``k``, ``diverged`` and ``N`` (keys ``k``, ``div``, ``N``).
    library : path-like
        A library built from :func:`runner_source`.

    Examples
    --------
    >>> from fl_design.sim.kernel._runners import NativeRunner
    >>> NativeRunner.__name__
    'NativeRunner'
    """

    compiled = True

    def __init__(self, accumulate: ca.Function, record: ca.Function, indices: dict, library):
        self.nacc = int(accumulate.size1_in(0))
        self.nout = int(record.size1_out(1))
        self._lib = _load(str(library))
        ThreadsOwner.__init__(self)

    def advance_rows(self, cols: np.ndarray, D: np.ndarray, *, threads: int = 1) -> None:
        """:meth:`run` in place on accumulators stored one run per row (``(ncols, nacc)``,
        C-contiguous float64): no transposed copies from block to block.

        Examples
        --------
        >>> from fl_design.sim.kernel._runners import NativeRunner
        >>> callable(NativeRunner.advance_rows)
        True
        """
        check_rows(cols, self.nacc)
        d = np.ascontiguousarray(np.asarray(D, dtype=float).T)
        nsteps = d.shape[0]

        ncols = cols.shape[0]
        # small pieces taken in turn by the threads (diverged runs stop early: an equal split
        # by count would leave one thread idle); each column is run alone: the same bits
        piece = max(1, math.ceil(ncols / (max(1, threads) * _PIECES)))
        taken = itertools.count()  # next() of a count is atomic under the GIL

        def work(_):
            while (a := next(taken) * piece) < ncols:
                b = min(a + piece, ncols)  # a row range of a C-contiguous array: run in place
                if self._lib.fl_run(cols[a:b], b - a, d, nsteps):
                    raise ComputationError("the compiled closed-loop kernel reported an error")

        self._share(work, max(1, min(int(threads), ncols)))

    def record(self, acc: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One column over the samples ``D``: final ``acc`` and ``out`` (``(nout, nsteps)``).

        Examples
        --------
        >>> from fl_design.sim.kernel._runners import NativeRunner
        >>> callable(NativeRunner.record)
        True
        """
        a = np.array(acc, dtype=float).ravel()  # a copy: the caller's acc is not changed
        d = np.ascontiguousarray(np.asarray(D, dtype=float).T)
        out = np.empty((d.shape[0], self.nout))
        if self._lib.fl_record(a, d, d.shape[0], out):
            raise ComputationError("the compiled closed-loop kernel reported an error")
        return a, out.T


class InterpretedRunner:
    """CasADi-interpreted runner with the interface of :class:`NativeRunner`.

    Samples are processed in blocks of ``block`` with ``fold``/``mapaccum`` (a padded last
    block is harmless: samples with ``k >= N`` are no-ops).

    Parameters
    ----------
    accumulate, record : casadi.Function
        As for :class:`NativeRunner`.
    indices : dict
        Accumulator positions ``k``, ``div``, ``N`` (to stop once every column diverged).
    block : int, optional
        Samples per CasADi call (default 100).

    Examples
    --------
    >>> from fl_design.sim.kernel._runners import InterpretedRunner
    >>> InterpretedRunner.compiled
    False
    """

    compiled = False

    def __init__(self, accumulate: ca.Function, record: ca.Function, indices: dict,
                 block: int = 100):
        self.indices = dict(indices)
        self.nacc = int(accumulate.size1_in(0))
        self.nout = int(record.size1_out(1))
        self.block = int(block)
        self._accumulate, self._record = accumulate, record
        self._folds: dict[int, ca.Function] = {}
        self._mapaccums: dict[int, ca.Function] = {}

    def _fold(self, n: int) -> ca.Function:
        if n not in self._folds:
            self._folds[n] = self._accumulate.fold(n)
        return self._folds[n]

    def _mapaccum(self, n: int) -> ca.Function:
        if n not in self._mapaccums:
            self._mapaccums[n] = self._record.mapaccum("fl_rec_acc", n)
        return self._mapaccums[n]

    def _blocks(self, D: np.ndarray):
        """Consecutive segments of ``D``; the last one exactly as long as what is left (no
        padding: samples past the given ones must not be run, the run may continue later)."""
        D = np.asarray(D, dtype=float)
        nsteps = D.shape[1]
        for start in range(0, nsteps, self.block):
            seg = D[:, start:start + self.block]
            yield start, seg.shape[1], seg

    def run(self, acc: np.ndarray, D: np.ndarray, *, threads: int = 1) -> np.ndarray:
        """As :meth:`NativeRunner.run` (``threads`` is ignored).

        Examples
        --------
        >>> from fl_design.sim.kernel._runners import InterpretedRunner
        >>> callable(InterpretedRunner.run)
        True
        """
        acc = np.asarray(acc, dtype=float).reshape(self.nacc, -1)
        i_k, i_div, i_n = self.indices["k"], self.indices["div"], self.indices["N"]
        nsteps = np.shape(D)[1]
        for start, used, seg in self._blocks(D):
            mapped = self._fold(used).map("fl_fold_map", "serial", acc.shape[1], [1], [])
            acc = np.asarray(mapped(acc, seg), dtype=float).reshape(self.nacc, -1)
            if np.all(acc[i_div] != 0):  # all frozen: the remaining samples only advance k
                acc[i_k] = np.minimum(acc[i_n], acc[i_k] + (nsteps - start - used))
                break
        return acc

    def record(self, acc: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`NativeRunner.record`.

        Examples
        --------
        >>> from fl_design.sim.kernel._runners import InterpretedRunner
        >>> callable(InterpretedRunner.record)
        True
        """
        a = np.asarray(acc, dtype=float).ravel()
        outs = []
        for _, used, seg in self._blocks(D):
            accs, out = self._mapaccum(used)(a, seg)
            a = np.asarray(accs, dtype=float)[:, -1]
            outs.append(np.asarray(out, dtype=float)[:, :used])
        return a, np.hstack(outs)


def runner_source(accumulate: ca.Function, record: ca.Function, indices: dict) -> str:
    """C source of the recording step plus the driver (``fl_run``, ``fl_record``).

    Only ``fl_rec`` is generated: ``fl_run`` calls it without an output array (CasADi's code
    then skips ``out``), its ``acc_next`` being ``fl_acc``'s by contract (the same expression,
    operation for operation: the same bits, ``tests/sim/test_kernel_lanes.py``). One step in
    the source instead of two halves its compile (0.7 -> 0.35 s at ``-O3`` on the TRMS loop).

    Parameters
    ----------
    accumulate, record : casadi.Function
        ``fl_acc(acc, d) -> acc_next`` (its shapes must be ``record``'s) and
        ``fl_rec(acc, d) -> (acc_next, out)``.
    indices : dict
        Accumulator positions ``k``, ``div``, ``N``.

    Returns
    -------
    str

    Raises
    ------
    ParameterError
        ``accumulate`` and ``record`` do not take and give the same accumulator.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import ClosedLoop
    >>> from fl_design.sim.kernel._runners import runner_source
    >>> loop = ClosedLoop(fl.plants.pendulum(), fl.presets.pendulum_design(), substeps=1)
    >>> sl = loop.layout.slices
    >>> src = runner_source(loop.accumulate, loop.record,
    ...                     {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start})
    >>> "int fl_rec(" in src, "int fl_acc(" in src
    (True, False)
    """
    shapes = lambda f: (f.size_in(0), f.size_in(1), f.size_out(0))
    if record.n_out() != 2 or shapes(accumulate) != shapes(record):
        raise ParameterError(
            "record must be fl_rec(acc, d) -> (acc_next, out) with the accumulator and samples "
            f"of accumulate: got {record.n_out()} outputs, shapes (acc, d, acc_next) "
            f"{shapes(record)} against accumulate's {shapes(accumulate)}")
    size = lambda v: max(1, int(v))
    values = {
        "NACC": record.size1_in(0), "NOUT": record.size1_out(1), "ND": record.size1_in(1),
        "REC_ARG": size(record.sz_arg()), "REC_RES": size(record.sz_res()),
        "REC_IW": size(record.sz_iw()), "REC_W": size(record.sz_w()),
        "I_K": indices["k"], "I_DIV": indices["div"], "I_N": indices["N"],
    }
    return generate_source(record) + "\n" + fill_template(_driver_template(), values)


@functools.lru_cache(maxsize=1)
def _driver_template() -> str:
    return resources.files(__package__).joinpath("templates/kernel_driver.c.in").read_text()


def make_runner(accumulate: ca.Function, record: ca.Function, indices: dict, *,
                compiled: bool = True, cache_dir=None, lanes: bool = True,
                vector_math: bool | None = None, isa: str | None = None):
    """A :class:`~fl_design.sim.kernel._lanes.LanesRunner`, a :class:`NativeRunner` or an interpreter.

    Compiled runners are built (and cached) on first use by the lanes runner: the lanes
    kernel for grids, the scalar :class:`NativeRunner` for recorded runs.

    With ``compiled=True`` and no working compiler, the interpreted runner is returned with a
    :class:`~fl_design.errors.CompilationWarning`.

    Parameters
    ----------
    accumulate, record : casadi.Function
        The steps.
    indices : dict
        Accumulator positions ``k``, ``div``, ``N``.
    compiled : bool, optional
        Compile to C (default) or interpret.
    cache_dir : path-like, optional
        See :func:`fl_design.codegen.cache_directory`.
    lanes : bool, optional
        With ``compiled``: the lanes kernel for grids (default) or the scalar one only.
    vector_math : bool, optional
        Lanes kernel with libmvec's vector math or glibc's scalar functions (bitwise the
        results of the scalar kernel and of the interpreter; slower). Default: vector math
        unless the environment variable ``FL_DESIGN_VECTOR_MATH`` is ``0``.
    isa : str, optional
        Instruction-set level of the lanes kernel (:func:`fl_design._isa.resolve_isa`:
        default ``$FL_DESIGN_ISA``, else the widest available; ``"scalar"``: no lanes).

    Examples
    --------
    >>> from fl_design.sim.kernel._runners import make_runner
    >>> callable(make_runner)
    True
    """
    if compiled and lanes and find_compiler() is not None:
        from ..._isa import resolve_isa
        from ._lanes import LanesRunner

        scalar = functools.partial(make_runner, accumulate, record, indices, compiled=True,
                                   cache_dir=cache_dir, lanes=False)
        if vector_math is None:
            vector_math = env_flag("FL_DESIGN_VECTOR_MATH", True)
        return LanesRunner(accumulate, record, indices, cache_dir=cache_dir, scalar=scalar,
                           vector_math=vector_math, isa=resolve_isa(isa))
    if compiled:
        source = runner_source(accumulate, record, indices)
        for _ in range(3):  # a library changed or damaged between build and load is rebuilt
            lib = build(source, "fl_loop", cache_dir=cache_dir)
            if lib is None:
                break
            try:
                return NativeRunner(accumulate, record, indices, lib)
            except (UnverifiedLibrary, OSError, AttributeError) as exc:
                problem = f"{type(exc).__name__}: {exc}"
                _load.cache_clear()
                discard(lib)
        else:
            warnings.warn(f"{problem} after 3 rebuilds: the loop runs in CasADi's interpreter, "
                          "with the same results but slower", CompilationWarning, stacklevel=2)
    return InterpretedRunner(accumulate, record, indices)



__all__ = ["InterpretedRunner", "NativeRunner", "ThreadsOwner", "make_runner", "runner_source"]
