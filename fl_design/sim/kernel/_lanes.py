"""The lanes runner: the sweep kernel on W grid points per SIMD vector (the default).

:class:`LanesRunner` compiles :func:`fl_design.sim.kernel._emit.lanes_source` of the
accumulating step for one instruction-set level (:mod:`fl_design._isa`: the widest this CPU
has, or the one ``fl.Kernel(isa=...)`` / ``$FL_DESIGN_ISA`` asks for; its lane width ``W``
and libmvec's vector ``tanh``/``sin``/``exp`` of that width) and runs the columns of a grid
through it: ``W`` lanes per thread, each lane refilled with the next column as soon as its run
has diverged or ended, the columns shared by the threads through one atomic counter (dynamic
load balance: diverged runs cost nothing, the order of the grid does not matter). One run with
its trajectory (:meth:`LanesRunner.record`, used by :func:`fl_design.simulate`) goes to the
scalar :class:`~fl_design.sim.NativeRunner`, built on first use; so does a whole grid at the
``scalar`` level, and so does a grid whose initial accumulators hold a ``-0.0`` or a
signalling NaN where the kernel assumes none (``fl_lanes_check``; the same bits, slower). With
glibc's scalar math (``vector_math=False``) results equal the scalar
kernel's and the interpreter's bit for bit at every level; with libmvec's (the default) every
classification is the same and metrics agree to the last bits of ``tanh``/``sin`` carried
through the loop (numbers in :class:`fl_design.Kernel`).

Fork safety (the rule): a runner's threads are created lazily, kept for its life, and belong to
the process that created them. A process forked from this one (``ProcessPoolExecutor`` with the
``fork`` start method, ``multiprocessing``, a notebook's ``os.fork``) inherits the pool object
but not its threads: the runner notices (``os.register_at_fork`` hook, and the owner's pid as a
second check: :class:`~fl_design.sim.kernel._runners.ThreadsOwner`) and starts fresh threads in
the child instead of waiting forever on the parent's. The same holds for its lock and the per-process memo of runners in
:mod:`fl_design.sim._grid`.

Examples
--------
>>> from fl_design.sim.kernel._lanes import lane_width
>>> lane_width("scalar")
1
"""

from __future__ import annotations

import ctypes
import functools
import os
import shutil
import warnings

import casadi as ca
import numpy as np

from ..._isa import Isa, mvec_functions, resolve_isa
from ..._toolchain import (
    LANES_CFLAGS,
    UnverifiedLibrary,
    build,
    discard,
    find_compiler,
    open_verified,
)
from ...errors import CompilationWarning, ComputationError
from ._emit import MATH, LanesUnsupported, groups, lanes_source
from ._threads import ThreadsOwner, check_rows


def lane_width(isa: str | None = None) -> int:
    """Doubles per vector of the lanes kernel at level ``isa`` (default: as resolved).

    Parameters
    ----------
    isa : str, optional
        An instruction-set level (:data:`fl_design._isa.LEVELS`); default ``$FL_DESIGN_ISA``,
        else the widest this machine has.

    Returns
    -------
    int
        8 (AVX-512), 4 (AVX2), 2 (SSE2, NEON, portable) or 1 (scalar kernel).

    Examples
    --------
    >>> from fl_design.sim.kernel._lanes import lane_width
    >>> lane_width() >= 1
    True
    """
    return resolve_isa(isa).width


def vector_math(isa: Isa | None = None) -> tuple[str, ...]:
    """Math functions with a libmvec vector version at level ``isa`` on this machine.

    Examples
    --------
    >>> from fl_design.sim.kernel._lanes import vector_math
    >>> isinstance(vector_math(), tuple)
    True
    """
    return mvec_functions(isa or resolve_isa(), tuple(sorted(set(MATH.values()))))


@functools.lru_cache(maxsize=32)
def _load(path: str) -> ctypes.CDLL:
    lib = open_verified(path)
    dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    lng = np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS")
    lib.fl_lanes_run.argtypes = [dbl, ctypes.c_long, dbl, ctypes.c_long, lng]
    lib.fl_lanes_run.restype = ctypes.c_int
    lib.fl_lanes_check.argtypes = [dbl, ctypes.c_long]
    lib.fl_lanes_check.restype = ctypes.c_int
    lib.fl_lanes_width.restype = ctypes.c_int
    return lib


def build_lanes(accumulate: ca.Function, indices: dict, *, isa: Isa | None = None,
                cache_dir=None, vector_math_ok: bool = True):
    """Compile (cached) the lanes kernel of ``accumulate`` for level ``isa``; path or None.

    Raises :class:`~fl_design.sim.kernel._emit.LanesUnsupported` for a step it cannot
    translate. With ``vector_math_ok=False`` math functions are glibc's scalar ones (bitwise
    the results of the scalar kernel and of the interpreter; the TRMS sweep 1.2x slower on
    AVX2, 1.7x on AVX-512). None for the ``scalar`` level or without a compiler. Compiled
    by :func:`preferred_compiler` when there is one (else, or if it fails, the default).

    Parameters
    ----------
    accumulate : casadi.Function
        ``fl_acc(acc, d) -> acc_next``.
    indices : dict
        Accumulator positions ``k``, ``div``, ``N``.
    isa : Isa, optional
        Instruction-set level (default :func:`fl_design._isa.resolve_isa`).
    cache_dir : path-like, optional
        Cache of compiled kernels.
    vector_math_ok : bool, optional
        Use libmvec's vector math (default).

    Returns
    -------
    pathlib.Path or None

    Examples
    --------
    >>> from fl_design.sim.kernel._lanes import build_lanes
    >>> callable(build_lanes)
    True
    """
    isa = isa or resolve_isa()
    if find_compiler() is None or not isa.lanes:
        return None
    maths = vector_math(isa) if vector_math_ok else ()
    flags, libs = (*isa.flags, *LANES_CFLAGS), ("-lmvec",) if maths else ()
    clang = preferred_compiler()
    if clang is not None:
        source = lanes_source(accumulate, indices, width=isa.width, vector_math=maths,
                              variant=isa.mvec, groups=groups(isa.width, 1, clang=True))
        with warnings.catch_warnings():  # a clang that fails: the default compiler, quietly
            warnings.simplefilter("ignore", CompilationWarning)
            path = build(source, f"fl_lanes_{isa.name}", cache_dir=cache_dir, compiler=clang,
                         extra_flags=flags, libs=libs)
        if path is not None:
            return path
    source = lanes_source(accumulate, indices, width=isa.width, vector_math=maths,
                          variant=isa.mvec)
    return build(source, f"fl_lanes_{isa.name}", cache_dir=cache_dir, extra_flags=flags,
                 libs=libs)


def preferred_compiler() -> str | None:
    """Clang for the lanes kernel when ``$CC`` is not set and ``clang`` is on the ``PATH``.

    Clang 14 compiles the TRMS step in 4 lane groups 3x faster than GCC 12 (0.5 s against
    1.5 s) and runs it faster (ns per run-sample, one thread, load 2-3: AVX2 41.8 against
    GCC's best 47.0, AVX-512 22.6 against 27.5; 10 substeps 175 / 108 against 179 / 113);
    the results are the same bit for bit. ``$CC`` set means that compiler, for everything.

    Examples
    --------
    >>> from fl_design.sim.kernel._lanes import preferred_compiler
    >>> preferred_compiler() is None or "clang" in preferred_compiler()
    True
    """
    if os.environ.get("CC", "").strip():
        return None
    return shutil.which("clang")


class LanesRunner(ThreadsOwner):
    """Compiled runner on W grid points per vector, with the interface of ``NativeRunner``.

    Parameters
    ----------
    accumulate, record, indices
        As in :class:`~fl_design.sim.kernel._runners.NativeRunner` (the step functions and
        the accumulator positions of ``k``, ``diverged`` and ``N``).
    cache_dir : path-like, optional
        Cache of compiled kernels.
    scalar : callable
        Returns the scalar runner that :meth:`record` uses (called once, on first use); it
        also runs grids whose step the lane emitter cannot translate.
    vector_math : bool, optional
        libmvec's vector ``tanh``, ``sin``, ... (default; they may differ from glibc's scalar
        functions in the last bit, which the high-gain loop amplifies to about 1e-9 relative
        in the metrics) or the scalar functions (bitwise the scalar kernel's results).
    isa : Isa, optional
        Instruction-set level (default :func:`fl_design._isa.resolve_isa`).

    Examples
    --------
    >>> from fl_design.sim.kernel._lanes import LanesRunner
    >>> LanesRunner.compiled
    True
    """

    compiled = True

    def __init__(self, accumulate: ca.Function, record: ca.Function, indices: dict, *,
                 cache_dir=None, scalar, vector_math: bool = True, isa: Isa | None = None):
        self.nacc = int(accumulate.size1_in(0))
        self.nout = int(record.size1_out(1))
        self._accumulate, self._indices, self._cache_dir = accumulate, dict(indices), cache_dir
        self.vector_math = bool(vector_math)
        self.isa = isa or resolve_isa()
        self._scalar_factory, self._scalar, self._lanes = scalar, None, None
        ThreadsOwner.__init__(self)

    @property
    def scalar(self):
        """The scalar runner (``NativeRunner``, or the interpreter without a compiler)."""
        with self._lock:
            if self._scalar is None:
                self._scalar = self._scalar_factory()
            return self._scalar

    @property
    def library(self) -> ctypes.CDLL | None:
        """The loaded lanes kernel (built on first use); None at the ``scalar`` level, if the
        step has no translation or nothing compiles (the scalar runner then runs the grid).

        A library that does not load (damaged after its check, a foreign file, a missing
        symbol) is removed from the cache and rebuilt once; if that fails too, the scalar
        kernel runs the grid, with a :class:`~fl_design.errors.CompilationWarning`.
        """
        with self._lock:
            if self._lanes is None:
                self._lanes = self._build_and_load() or False
            return self._lanes or None

    def _build_and_load(self) -> ctypes.CDLL | None:
        problem = None
        for _ in range(2):
            try:
                path = build_lanes(self._accumulate, self._indices, isa=self.isa,
                                   cache_dir=self._cache_dir, vector_math_ok=self.vector_math)
            except LanesUnsupported:
                return None
            if path is None:
                return None
            try:
                lib = _load(str(path))
                if lib.fl_lanes_width() != self.isa.width:
                    raise OSError(f"{path} runs {lib.fl_lanes_width()} lanes, not "
                                  f"{self.isa.width}")
                return lib
            except (UnverifiedLibrary, OSError, AttributeError) as exc:
                problem = f"{type(exc).__name__}: {exc}"
                _load.cache_clear()
                discard(path)
        warnings.warn(f"the compiled lanes kernel could not be loaded even after a rebuild "
                      f"({problem}); the scalar compiled kernel runs the grid (same results, "
                      "slower)", CompilationWarning, stacklevel=4)
        return None

    def advance_rows(self, cols: np.ndarray, D: np.ndarray, *, threads: int = 1) -> None:
        """:meth:`run` in place on accumulators stored one run per row (no transposed copies).

        A grid run in blocks of samples keeps its accumulators in this layout from block to
        block (:func:`fl_design.sim._grid.run_grid`).

        Parameters
        ----------
        cols : numpy.ndarray
            ``(ncols, nacc)`` C-contiguous float64 accumulators, advanced in place.
        D : numpy.ndarray
            ``(2, nsteps)`` samples ``(r_k, w_k)``.
        threads : int, optional
            Threads sharing the columns (default 1).

        Examples
        --------
        >>> from fl_design.sim.kernel._lanes import LanesRunner
        >>> callable(LanesRunner.advance_rows)
        True
        """
        check_rows(cols, self.nacc)
        lib = self.library
        ncols = cols.shape[0]
        if lib is None or not lib.fl_lanes_check(cols, ncols):  # no lanes kernel, or an
            # initial -0.0 where the kernel assumes none: the scalar kernel (the same bits)
            scalar = self.scalar
            if hasattr(scalar, "advance_rows"):
                scalar.advance_rows(cols, D, threads=threads)
            else:  # the interpreter (no compiler)
                cols[...] = scalar.run(cols.T, D, threads=threads).T
            return
        width = int(lib.fl_lanes_width())
        d = np.ascontiguousarray(np.asarray(D, dtype=float).T)
        nsteps = d.shape[0]
        counter = np.zeros(1, dtype=np.int64)
        n_thr = max(1, min(int(threads), -(-ncols // width)))

        def work(_):
            if lib.fl_lanes_run(cols, ncols, d, nsteps, counter):
                raise ComputationError("the compiled lanes kernel reported an error")

        self._share(work, n_thr)

    def record(self, acc: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One column with its trajectory, by the scalar compiled kernel (built on first use).

        Parameters
        ----------
        acc : numpy.ndarray
            ``(nacc,)`` accumulator (not modified).
        D : numpy.ndarray
            ``(2, nsteps)`` samples.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            Final accumulator and ``(nout, nsteps)`` recorded rows.

        Examples
        --------
        >>> from fl_design.sim.kernel._lanes import LanesRunner
        >>> callable(LanesRunner.record)
        True
        """
        return self.scalar.record(acc, D)


__all__ = ["LanesRunner", "build_lanes", "lane_width", "preferred_compiler", "vector_math"]
