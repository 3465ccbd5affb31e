"""The lanes runner: the sweep kernel on W grid points per SIMD vector (the default).

:class:`LanesRunner` compiles :func:`fl_design.sim._lanes_emit.lanes_source` of the
accumulating step for this machine (:data:`fl_design.codegen._build.NATIVE_CFLAGS`: its vector
width, libmvec's vector ``tanh``/``sin``/``exp``) and runs the columns of a grid through it:
``W`` lanes per thread, each lane refilled with the next column as soon as its run has
diverged or ended, the columns shared by the threads through one atomic counter (dynamic load
balance: diverged runs cost nothing, the order of the grid does not matter). One run with its
trajectory (:meth:`LanesRunner.record`, used by :func:`fl_design.simulate`) goes to the scalar
:class:`~fl_design.sim.NativeRunner`, built on first use. With glibc's scalar math
(``vector_math=False``) results equal the scalar kernel's and the interpreter's bit for bit;
with libmvec's (the default) every classification is the same and metrics agree to the last
bits of ``tanh``/``sin`` carried through the loop (numbers in :class:`fl_design.Kernel`).

W is the compiler's: 8 doubles with AVX-512, 4 with AVX, else 2.

Examples
--------
>>> from fl_design.sim._lanes import lane_width
>>> lane_width() in (2, 4, 8)
True
"""

from __future__ import annotations

import ctypes
import functools
import threading
from concurrent.futures import ThreadPoolExecutor

import casadi as ca
import numpy as np

from ..codegen._build import NATIVE_CFLAGS, build, find_compiler, native_macros, verified
from ..errors import ComputationError
from ._lanes_emit import MATH, LanesUnsupported, lanes_source


def lane_width(compiler: str | None = None) -> int:
    """Doubles per vector register of this machine as the compiler sees it (8, 4 or 2).

    Parameters
    ----------
    compiler : str, optional
        Default :func:`fl_design.codegen.find_compiler`.

    Returns
    -------
    int

    Examples
    --------
    >>> from fl_design.sim._lanes import lane_width
    >>> lane_width() >= 2
    True
    """
    macros = native_macros(compiler)
    return 8 if "__AVX512F__" in macros else 4 if "__AVX__" in macros else 2


@functools.lru_cache(maxsize=1)
def vector_math() -> tuple[str, ...]:
    """Math functions with a vector version in glibc's libmvec on this machine.

    Examples
    --------
    >>> from fl_design.sim._lanes import vector_math
    >>> isinstance(vector_math(), tuple)
    True
    """
    try:
        lib = ctypes.CDLL("libmvec.so.1")
    except OSError:
        return ()
    width = lane_width()
    isa = {8: "e", 4: "d", 2: "b"}[width]
    return tuple(sorted(name for name in set(MATH.values())
                        if hasattr(lib, f"_ZGV{isa}N{width}v_{name}")))


@functools.lru_cache(maxsize=32)
def _load(path: str) -> ctypes.CDLL:
    lib = ctypes.CDLL(path)
    dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    lng = np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS")
    lib.fl_lanes_run.argtypes = [dbl, ctypes.c_long, dbl, ctypes.c_long, lng]
    lib.fl_lanes_run.restype = ctypes.c_int
    lib.fl_lanes_width.restype = ctypes.c_int
    return lib


def build_lanes(accumulate: ca.Function, indices: dict, *, cache_dir=None,
                vector_math_ok: bool = True):
    """Compile (cached) the lanes kernel of ``accumulate``; the library path or None.

    Raises :class:`~fl_design.sim._lanes_emit.LanesUnsupported` for a step it cannot
    translate. With ``vector_math_ok=False`` math functions are glibc's scalar ones (bitwise
    the results of the scalar kernel and of the interpreter, 4x slower on the TRMS loop).

    Parameters
    ----------
    accumulate : casadi.Function
        ``fl_acc(acc, d) -> acc_next``.
    indices : dict
        Accumulator positions ``k``, ``div``, ``N``.
    cache_dir : path-like, optional
        Cache of compiled kernels.
    vector_math_ok : bool, optional
        Use libmvec's vector math (default).

    Returns
    -------
    pathlib.Path or None

    Examples
    --------
    >>> from fl_design.sim._lanes import build_lanes
    >>> callable(build_lanes)
    True
    """
    cc = find_compiler()
    if cc is None or not native_macros(cc):  # no compiler, or no -march=native: scalar kernel
        return None
    maths = vector_math() if vector_math_ok else ()
    source = lanes_source(accumulate, indices, width=lane_width(cc), vector_math=maths)
    return build(source, "fl_lanes", cache_dir=cache_dir, extra_flags=NATIVE_CFLAGS,
                 libs=("-lmvec",) if maths else ())


class LanesRunner:
    """Compiled runner on W grid points per vector, with the interface of ``NativeRunner``.

    Parameters
    ----------
    accumulate, record : casadi.Function
        ``fl_acc(acc, d) -> acc_next`` and ``fl_rec(acc, d) -> (acc_next, out)``.
    indices : dict
        Accumulator positions of ``k``, ``diverged`` and ``N`` (keys ``k``, ``div``, ``N``).
    cache_dir : path-like, optional
        Cache of compiled kernels.
    scalar : callable
        Returns the scalar runner that :meth:`record` uses (called once, on first use); it
        also runs grids whose step the lane emitter cannot translate.
    vector_math : bool, optional
        libmvec's vector ``tanh``, ``sin``, ... (default; they may differ from glibc's scalar
        functions in the last bit, which the high-gain loop amplifies to about 1e-9 relative
        in the metrics) or the scalar functions (bitwise the scalar kernel's results).

    Examples
    --------
    >>> from fl_design.sim._lanes import LanesRunner
    >>> LanesRunner.compiled
    True
    """

    compiled = True

    def __init__(self, accumulate: ca.Function, record: ca.Function, indices: dict, *,
                 cache_dir=None, scalar, vector_math: bool = True):
        self.nacc = int(accumulate.size1_in(0))
        self.nout = int(record.size1_out(1))
        self._accumulate, self._indices, self._cache_dir = accumulate, dict(indices), cache_dir
        self.vector_math = bool(vector_math)
        self._scalar_factory, self._scalar, self._lanes = scalar, None, None
        self._lock = threading.Lock()
        self._pools: list[tuple[int, ThreadPoolExecutor]] = []

    def _pool(self, n: int) -> ThreadPoolExecutor:
        """Threads kept for the runner's life (a sweep calls :meth:`run` once per chunk).

        A larger request adds a larger pool; pools are only shut down with the runner, so a
        concurrent :meth:`run` never meets a closed one.
        """
        with self._lock:
            if not self._pools or self._pools[-1][0] < n:
                self._pools.append((n, ThreadPoolExecutor(n, thread_name_prefix="fl_lanes")))
            return self._pools[-1][1]

    def __del__(self):
        for _, pool in getattr(self, "_pools", ()):
            pool.shutdown(wait=False)

    @property
    def scalar(self):
        """The scalar runner (``NativeRunner``, or the interpreter without a compiler)."""
        with self._lock:
            if self._scalar is None:
                self._scalar = self._scalar_factory()
            return self._scalar

    @property
    def library(self) -> ctypes.CDLL | None:
        """The loaded lanes kernel (built on first use); None if the step has no translation
        or nothing compiles (the scalar runner then runs the grid)."""
        with self._lock:
            if self._lanes is None:
                try:
                    path = build_lanes(self._accumulate, self._indices,
                                       cache_dir=self._cache_dir,
                                       vector_math_ok=self.vector_math)
                except LanesUnsupported:
                    path = None
                if path is not None and not verified(path):  # changed since it was built
                    path = None
                self._lanes = False if path is None else _load(str(path))
            return self._lanes or None

    def run(self, acc: np.ndarray, D: np.ndarray, *, threads: int = 1) -> np.ndarray:
        """Advance every column of ``acc`` (``(nacc, ncols)``) over the samples ``D`` (2, nsteps).

        Parameters
        ----------
        acc : numpy.ndarray
            ``(nacc, ncols)`` accumulators (not modified).
        D : numpy.ndarray
            ``(2, nsteps)`` samples ``(r_k, w_k)``.
        threads : int, optional
            Threads sharing the columns (default 1).

        Returns
        -------
        numpy.ndarray
            ``(nacc, ncols)`` final accumulators.

        Examples
        --------
        >>> from fl_design.sim._lanes import LanesRunner
        >>> callable(LanesRunner.run)
        True
        """
        lib = self.library
        if lib is None:
            return self.scalar.run(acc, D, threads=threads)
        width = int(lib.fl_lanes_width())
        cols = np.ascontiguousarray(np.asarray(acc, dtype=float).reshape(self.nacc, -1).T)
        d = np.ascontiguousarray(np.asarray(D, dtype=float).T)
        ncols, nsteps = cols.shape[0], d.shape[0]
        counter = np.zeros(1, dtype=np.int64)
        n_thr = max(1, min(int(threads), -(-ncols // width)))

        def work(_):
            if lib.fl_lanes_run(cols, ncols, d, nsteps, counter):
                raise ComputationError("the compiled lanes kernel reported an error")

        if n_thr > 1:
            list(self._pool(n_thr).map(work, range(n_thr)))
        else:
            work(0)
        return cols.T.copy()

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
        >>> from fl_design.sim._lanes import LanesRunner
        >>> callable(LanesRunner.record)
        True
        """
        return self.scalar.record(acc, D)


__all__ = ["LanesRunner", "build_lanes", "lane_width", "vector_math"]
