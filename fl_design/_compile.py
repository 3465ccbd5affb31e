"""Run the closed-loop step over time and parameter columns: compiled C, or CasADi's interpreter.

The accumulating step ``fl_acc(acc, d) -> acc_next`` and the recording step ``fl_rec(acc, d) ->
(acc_next, out)`` of :class:`fl_design.closed_loop.ClosedLoop` are CasADi functions. Two
runners evaluate them over ``nsteps`` samples and many accumulator columns (one per grid point),
with the same interface and the same results:

* :class:`NativeRunner` (default): CasADi generates the C code of both steps
  (``casadi.CodeGenerator``); a 40-line C driver appended to it loops over columns and samples
  (double-buffered accumulators, no copies) and stops a column as soon as it has diverged
  (the remaining samples of a frozen run only advance its counter ``k``, which the driver adds
  at once). The source is compiled with the system C compiler (``cc -O3 -shared -fPIC``;
  portable: no ``-march=native``, and no ``-ffast-math``, which would break the NaN tests of
  the divergence detection) and called through ``ctypes``, which releases the GIL: columns are
  split over threads.
* :class:`InterpretedRunner`: the same steps folded with CasADi (``fold``/``mapaccum`` over
  blocks of samples, padded samples are no-ops) in CasADi's virtual machine. Used, with a
  :class:`~fl_design.errors.CompilationWarning` (never silently), when no C compiler works, or
  on request.

Why a C driver rather than compiling CasADi's own ``fold``/``map``: CasADi unrolls ``fold`` as
a tower of ``mapaccum`` levels that store and copy every intermediate accumulator; measured on
the TRMS loop this costs 1.4-2x the plain C loop, against about 1.1x for the driver (see
``verify/bench_sweep.py``).

Libraries are cached under a name made from the SHA-256 hash of the source, the compiler, its
flags and the CasADi version, so an unchanged kernel is never compiled twice (across processes
and sessions); the file is written atomically (temporary name, then ``os.replace``) so that
workers sharing the cache never load a half-written library. Cache directory, in order: the
``cache_dir`` argument, ``$FL_DESIGN_CACHE``, ``$XDG_CACHE_HOME/fl_design``,
``~/.cache/fl_design``.

Examples
--------
>>> from fl_design._compile import cache_directory
>>> cache_directory("kernels").name
'kernels'
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import math
import os
import shutil
import subprocess
import tempfile
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import casadi as ca
import numpy as np

from .errors import CompilationWarning, ComputationError

#: Compiler flags of the kernels (``-fno-math-errno`` only lets ``sqrt`` inline; IEEE kept).
CFLAGS = ("-O3", "-std=c99", "-fno-math-errno", "-fPIC")

_DRIVER = r"""
/* ---- fl_design driver: fold over samples, map over accumulator columns ---- */
#define FL_NACC {nacc}
#define FL_NOUT {nout}
int fl_run(casadi_real* acc, long ncols, const casadi_real* D, long nsteps) {{
  const casadi_real* arg[{acc_arg}]; casadi_real* res[{acc_res}];
  casadi_int iw[{acc_iw}]; casadi_real w[{acc_w}];
  casadi_real buf[2][FL_NACC];
  long j, i, c;
  for (j = 0; j < ncols; ++j) {{
    casadi_real* a = acc + j * FL_NACC;
    int cur = 0;
    for (c = 0; c < FL_NACC; ++c) buf[0][c] = a[c];
    for (i = 0; i < nsteps; ++i) {{
      if (buf[cur][{i_div}] != 0) {{  /* frozen: the remaining samples only advance k */
        casadi_real k = buf[cur][{i_k}] + (casadi_real)(nsteps - i);
        buf[cur][{i_k}] = k < buf[cur][{i_n}] ? k : buf[cur][{i_n}];
        break;
      }}
      arg[0] = buf[cur]; arg[1] = D + 2 * i; res[0] = buf[1 - cur];
      if (fl_acc(arg, res, iw, w, 0)) return 1;
      cur = 1 - cur;
    }}
    for (c = 0; c < FL_NACC; ++c) a[c] = buf[cur][c];
  }}
  return 0;
}}

int fl_record(casadi_real* acc, const casadi_real* D, long nsteps, casadi_real* out) {{
  const casadi_real* arg[{rec_arg}]; casadi_real* res[{rec_res}];
  casadi_int iw[{rec_iw}]; casadi_real w[{rec_w}];
  casadi_real buf[2][FL_NACC];
  long i, c;
  int cur = 0;
  for (c = 0; c < FL_NACC; ++c) buf[0][c] = acc[c];
  for (i = 0; i < nsteps; ++i) {{
    arg[0] = buf[cur]; arg[1] = D + 2 * i; res[0] = buf[1 - cur]; res[1] = out + i * FL_NOUT;
    if (fl_rec(arg, res, iw, w, 0)) return 1;
    cur = 1 - cur;
  }}
  for (c = 0; c < FL_NACC; ++c) acc[c] = buf[cur][c];
  return 0;
}}
"""


def cache_directory(cache_dir: str | os.PathLike | None = None) -> Path:
    """The directory holding compiled kernels (created if needed).

    Parameters
    ----------
    cache_dir : path-like, optional
        Explicit directory; default ``$FL_DESIGN_CACHE``, else ``$XDG_CACHE_HOME/fl_design``,
        else ``~/.cache/fl_design``.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> from fl_design._compile import cache_directory
    >>> cache_directory("kernels").is_dir()
    True
    """
    if cache_dir is None:
        cache_dir = os.environ.get("FL_DESIGN_CACHE") or os.path.join(
            os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
            "fl_design")
    path = Path(cache_dir)
    path.mkdir(parents=True, exist_ok=True)
    return path


def find_compiler() -> str | None:
    """Path of the C compiler: ``$CC`` if set, else ``cc``, ``gcc`` or ``clang``, else None.

    Examples
    --------
    >>> from fl_design._compile import find_compiler
    >>> find_compiler() is None or os.path.isabs(find_compiler())
    True
    """
    env = os.environ.get("CC")
    for name in [env] if env else ["cc", "gcc", "clang"]:
        path = shutil.which(name)
        if path:
            return path
    return None


def generate_source(*functions: ca.Function) -> str:
    """The C source CasADi generates for ``functions`` (no header, no main).

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design._compile import generate_source
    >>> x = ca.SX.sym("x")
    >>> "int twice(" in generate_source(ca.Function("twice", [x], [2 * x]))
    True
    """
    cg = ca.CodeGenerator("fl_kernel.c", {"with_header": False, "verbose": False})
    for fn in functions:
        cg.add(fn)
    return cg.dump()


def build(source: str, name: str, *, shared: bool = True, cache_dir=None,
          compiler: str | None = None) -> Path | None:
    """Compile ``source`` once (cached by hash); the library/executable path, or None.

    Returns None, with a :class:`~fl_design.errors.CompilationWarning`, when no compiler is
    found or compilation fails.

    Parameters
    ----------
    source : str
        C99 source.
    name : str
        Prefix of the file name.
    shared : bool, optional
        Build a shared library (default) or an executable.
    cache_dir : path-like, optional
        See :func:`cache_directory`.
    compiler : str, optional
        Default :func:`find_compiler`.

    Examples
    --------
    >>> from fl_design._compile import build
    >>> build("int one(void) { return 1; }", "one", cache_dir=".").suffix
    '.so'
    """
    cc = compiler or find_compiler()
    if cc is None:
        warnings.warn(f"no C compiler found (set $CC or install gcc/clang): {name} runs in "
                      "CasADi's interpreter, with the same results but 3-20x slower",
                      CompilationWarning, stacklevel=3)
        return None
    flags = [*CFLAGS, "-shared"] if shared else list(CFLAGS)
    key = hashlib.sha256("\n".join([source, cc, *flags, ca.__version__]).encode()).hexdigest()
    out = cache_directory(cache_dir) / f"{name}_{key[:24]}{'.so' if shared else '.bin'}"
    if out.exists():
        return out
    with tempfile.TemporaryDirectory(dir=out.parent) as tmp:
        c_file, tmp_out = Path(tmp) / f"{name}.c", Path(tmp) / out.name
        c_file.write_text(source)
        try:
            proc = subprocess.run([cc, *flags, str(c_file), "-o", str(tmp_out), "-lm"],
                                  capture_output=True, text=True, timeout=900, check=False)
            error = None if proc.returncode == 0 else (proc.stderr.strip()[-400:] or "failed")
        except (OSError, subprocess.TimeoutExpired) as exc:
            error = str(exc)
        if error is not None:
            warnings.warn(f"compiling {name} with {cc} failed ({error}); it runs in CasADi's "
                          "interpreter, with the same results but slower",
                          CompilationWarning, stacklevel=3)
            return None
        os.replace(tmp_out, out)
    return out


@functools.lru_cache(maxsize=32)
def _load(path: str) -> ctypes.CDLL:
    lib = ctypes.CDLL(path)
    dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    lib.fl_run.argtypes = [dbl, ctypes.c_long, dbl, ctypes.c_long]
    lib.fl_run.restype = ctypes.c_int
    lib.fl_record.argtypes = [dbl, dbl, ctypes.c_long, dbl]
    lib.fl_record.restype = ctypes.c_int
    return lib


def _split(ncols: int, parts: int) -> list[tuple[int, int]]:
    step = math.ceil(ncols / max(1, parts))
    return [(a, min(a + step, ncols)) for a in range(0, ncols, step)]


class NativeRunner:
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
    >>> from fl_design._compile import NativeRunner
    >>> NativeRunner.__name__
    'NativeRunner'
    """

    compiled = True

    def __init__(self, accumulate: ca.Function, record: ca.Function, indices: dict, library):
        self.nacc = int(accumulate.size1_in(0))
        self.nout = int(record.size1_out(1))
        self._lib = _load(str(library))

    def run(self, acc: np.ndarray, D: np.ndarray, *, threads: int = 1) -> np.ndarray:
        """Advance every column of ``acc`` (``(nacc, ncols)``) over the samples ``D`` (2, nsteps).

        Examples
        --------
        >>> from fl_design._compile import NativeRunner
        >>> callable(NativeRunner.run)
        True
        """
        cols = np.ascontiguousarray(np.asarray(acc, dtype=float).T)
        d = np.ascontiguousarray(np.asarray(D, dtype=float).T)
        nsteps = d.shape[0]

        def part(bounds):
            a, b = bounds
            chunk = np.ascontiguousarray(cols[a:b])
            if self._lib.fl_run(chunk, b - a, d, nsteps):
                raise ComputationError("the compiled closed-loop kernel reported an error")
            cols[a:b] = chunk

        pieces = _split(cols.shape[0], threads)
        if len(pieces) > 1:
            with ThreadPoolExecutor(len(pieces)) as pool:
                list(pool.map(part, pieces))
        else:
            for piece in pieces:
                part(piece)
        return cols.T.copy()

    def record(self, acc: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One column over the samples ``D``: final ``acc`` and ``out`` (``(nout, nsteps)``).

        Examples
        --------
        >>> from fl_design._compile import NativeRunner
        >>> callable(NativeRunner.record)
        True
        """
        a = np.ascontiguousarray(np.asarray(acc, dtype=float).ravel())
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
    >>> from fl_design._compile import InterpretedRunner
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
        self._fold = accumulate.fold(self.block)
        self._mapaccum = record.mapaccum("fl_rec_acc", self.block)

    def _blocks(self, D: np.ndarray):
        D = np.asarray(D, dtype=float)
        nsteps = D.shape[1]
        for start in range(0, nsteps, self.block):
            seg = D[:, start:start + self.block]
            if seg.shape[1] < self.block:
                seg = np.hstack([seg, np.zeros((2, self.block - seg.shape[1]))])
            yield start, min(self.block, nsteps - start), seg

    def run(self, acc: np.ndarray, D: np.ndarray, *, threads: int = 1) -> np.ndarray:
        """As :meth:`NativeRunner.run` (``threads`` is ignored).

        Examples
        --------
        >>> from fl_design._compile import InterpretedRunner
        >>> callable(InterpretedRunner.run)
        True
        """
        acc = np.asarray(acc, dtype=float).reshape(self.nacc, -1)
        mapped = self._fold.map("fl_fold_map", "serial", acc.shape[1], [1], [])
        i_k, i_div, i_n = self.indices["k"], self.indices["div"], self.indices["N"]
        nsteps = np.shape(D)[1]
        for start, used, seg in self._blocks(D):
            acc = np.asarray(mapped(acc, seg), dtype=float).reshape(self.nacc, -1)
            if np.all(acc[i_div] != 0):  # all frozen: the remaining samples only advance k
                acc[i_k] = np.minimum(acc[i_n], acc[i_k] + (nsteps - start - used))
                break
        return acc

    def record(self, acc: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`NativeRunner.record`.

        Examples
        --------
        >>> from fl_design._compile import InterpretedRunner
        >>> callable(InterpretedRunner.record)
        True
        """
        a = np.asarray(acc, dtype=float).ravel()
        outs = []
        for _, used, seg in self._blocks(D):
            accs, out = self._mapaccum(a, seg)
            a = np.asarray(accs, dtype=float)[:, -1]
            outs.append(np.asarray(out, dtype=float)[:, :used])
        return a, np.hstack(outs)


def runner_source(accumulate: ca.Function, record: ca.Function, indices: dict) -> str:
    """C source of both steps plus the driver (``fl_run``, ``fl_record``).

    Examples
    --------
    >>> from fl_design._compile import runner_source
    >>> callable(runner_source)
    True
    """
    size = lambda v: max(1, int(v))
    return generate_source(accumulate, record) + _DRIVER.format(
        nacc=accumulate.size1_in(0), nout=record.size1_out(1),
        acc_arg=size(accumulate.sz_arg()), acc_res=size(accumulate.sz_res()),
        acc_iw=size(accumulate.sz_iw()), acc_w=size(accumulate.sz_w()),
        rec_arg=size(record.sz_arg()), rec_res=size(record.sz_res()),
        rec_iw=size(record.sz_iw()), rec_w=size(record.sz_w()),
        i_k=indices["k"], i_div=indices["div"], i_n=indices["N"],
    )


def make_runner(accumulate: ca.Function, record: ca.Function, indices: dict, *,
                compiled: bool = True, cache_dir=None):
    """A :class:`NativeRunner` (compiled, cached) or an :class:`InterpretedRunner`.

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
        See :func:`cache_directory`.

    Examples
    --------
    >>> from fl_design._compile import make_runner
    >>> callable(make_runner)
    True
    """
    if compiled:
        lib = build(runner_source(accumulate, record, indices), "fl_loop", cache_dir=cache_dir)
        if lib is not None:
            return NativeRunner(accumulate, record, indices, lib)
    return InterpretedRunner(accumulate, record, indices)


__all__ = ["CFLAGS", "InterpretedRunner", "NativeRunner", "build", "cache_directory",
           "find_compiler", "generate_source", "make_runner", "runner_source"]
