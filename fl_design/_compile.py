"""Compile a CasADi function to native code once, cache it on disk, load it back.

The closed-loop kernels of :mod:`fl_design.sweep` and :mod:`fl_design.simulation` are CasADi
``Function``\\ s. :func:`compiled` generates their C code (``Function.generate``), compiles it
with the system C compiler (``cc -O3 -shared -fPIC``, portable: no ``-march=native``, no
``-ffast-math`` which would break the NaN checks of the divergence detection) and loads the
shared library with ``casadi.external``. The library is cached under a name made from the
SHA-256 hash of the generated source, the compiler command and the CasADi version, so that an
unchanged kernel is never compiled twice, also across processes and sessions; the file is
written atomically (compile to a temporary name, then ``os.replace``) so that concurrent workers
sharing the cache directory never load a half-written library.

Cache directory, in order: the ``cache_dir`` argument, the ``FL_DESIGN_CACHE`` environment
variable, ``$XDG_CACHE_HOME/fl_design``, ``~/.cache/fl_design``.

Without a working C compiler the interpreted CasADi function is returned with a
:class:`~fl_design.errors.CompilationWarning` (never silently): the results are the same, only
slower.

Examples
--------
>>> import casadi as ca
>>> from fl_design._compile import compiled
>>> x = ca.SX.sym("x")
>>> f = ca.Function("square_plus_one", [x], [x * x + 1])
>>> g = compiled(f, cache_dir=".")   # doctest: +SKIP
>>> float(g(3.0))                    # doctest: +SKIP
10.0
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import subprocess
import tempfile
import warnings
from pathlib import Path

import casadi as ca

from .errors import CompilationWarning

#: Flags of the kernels: optimised, position independent, standard C. ``-fno-math-errno`` only
#: lets ``sqrt`` and friends inline (no ``errno``); IEEE semantics (NaN, inf) are kept.
CFLAGS = ("-O3", "-shared", "-fPIC", "-std=c99", "-fno-math-errno")


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
    >>> cache_directory("kernels").name
    'kernels'
    """
    if cache_dir is None:
        env = os.environ.get("FL_DESIGN_CACHE")
        if env:
            cache_dir = env
        else:
            base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"),
                                                                   ".cache")
            cache_dir = os.path.join(base, "fl_design")
    path = Path(cache_dir)
    path.mkdir(parents=True, exist_ok=True)
    return path


def find_compiler() -> str | None:
    """Path of the C compiler: ``$CC`` if set, else ``cc`` or ``gcc`` on the PATH, else None.

    Examples
    --------
    >>> from fl_design._compile import find_compiler
    >>> find_compiler() is None or isinstance(find_compiler(), str)
    True
    """
    env = os.environ.get("CC")
    candidates = [env] if env else ["cc", "gcc", "clang"]
    for name in candidates:
        path = shutil.which(name)
        if path:
            return path
    return None


def generate_source(fn: ca.Function) -> str:
    """The C source CasADi generates for ``fn`` (no header, no main).

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design._compile import generate_source
    >>> x = ca.SX.sym("x")
    >>> "int twice(" in generate_source(ca.Function("twice", [x], [2 * x]))
    True
    """
    cg = ca.CodeGenerator(f"{fn.name()}.c", {"with_header": False, "verbose": False})
    cg.add(fn)
    return cg.dump()


def compiled(fn: ca.Function, *, cache_dir: str | os.PathLike | None = None,
             compiler: str | None = None) -> ca.Function:
    """``fn`` compiled to a shared library (cached by source hash) and loaded back.

    Parameters
    ----------
    fn : casadi.Function
        The function; its name must be a valid C identifier.
    cache_dir : path-like, optional
        Where the libraries live (see :func:`cache_directory`).
    compiler : str, optional
        C compiler executable (default :func:`find_compiler`).

    Returns
    -------
    casadi.Function
        ``casadi.external(fn.name(), library)`` with the same inputs and outputs as ``fn``, or
        ``fn`` itself (with a :class:`~fl_design.errors.CompilationWarning`) when no compiler is
        available or compilation fails.

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design._compile import compiled
    >>> x = ca.SX.sym("x")
    >>> g = compiled(ca.Function("cube", [x], [x**3]), cache_dir=".")
    >>> float(g(2.0))
    8.0
    """
    cc = compiler or find_compiler()
    if cc is None:
        warnings.warn(
            f"no C compiler found (set $CC or install gcc/clang): {fn.name()!r} runs in CasADi's "
            "interpreter, with the same results but typically 3-20x slower",
            CompilationWarning, stacklevel=2,
        )
        return fn
    source = generate_source(fn)
    key = hashlib.sha256("\n".join([source, cc, *CFLAGS, ca.__version__]).encode()).hexdigest()
    lib = cache_directory(cache_dir) / f"{fn.name()}_{key[:24]}.so"
    if not lib.exists():
        error = _build(source, lib, cc)
        if error is not None:
            warnings.warn(
                f"compiling {fn.name()!r} with {cc} failed ({error}); it runs in CasADi's "
                "interpreter, with the same results but slower",
                CompilationWarning, stacklevel=2,
            )
            return fn
    return _load(fn.name(), str(lib))


def _build(source: str, lib: Path, cc: str) -> str | None:
    """Compile ``source`` to ``lib`` atomically; return an error text or None."""
    with tempfile.TemporaryDirectory(dir=lib.parent) as tmp:
        c_file = Path(tmp) / "kernel.c"
        c_file.write_text(source)
        out = Path(tmp) / lib.name
        try:
            proc = subprocess.run([cc, *CFLAGS, str(c_file), "-o", str(out), "-lm"],
                                  capture_output=True, text=True, timeout=600)
        except (OSError, subprocess.TimeoutExpired) as exc:
            return str(exc)
        if proc.returncode != 0:
            return proc.stderr.strip()[-400:] or f"exit status {proc.returncode}"
        os.replace(out, lib)
    return None


@functools.lru_cache(maxsize=64)
def _load(name: str, path: str) -> ca.Function:
    """Load a compiled library once per process (loading is cheap, but not free)."""
    return ca.external(name, path)


__all__ = ["CFLAGS", "cache_directory", "compiled", "find_compiler", "generate_source"]
