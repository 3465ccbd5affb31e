"""C compiler discovery, flag sets and the content-hash cache of compiled libraries.

Every compiled artefact of fl_design (the closed-loop sweep kernel of :mod:`fl_design.sim`, the
exported step of :func:`fl_design.generate_c`) goes through :func:`build`: the source is
compiled once with the system C compiler and cached under a name made from the SHA-256 hash
of the source, the compiler, its flags and the CasADi version, so an unchanged kernel is
never compiled twice (across processes and sessions). The file is written atomically
(temporary name, then ``os.replace``) so that workers sharing the cache never load a
half-written library.

Flag sets: :data:`CFLAGS` (fast, portable: ``-O3``, no ``-march=native``, no
``-ffast-math``, which would break the NaN tests of the divergence detection) and
:data:`STRICT_CFLAGS` (``-std=c99 -pedantic -Wall -Wextra -Werror``, for exported code).

Cache directory, in order: the ``cache_dir`` argument, ``$FL_DESIGN_CACHE``,
``$XDG_CACHE_HOME/fl_design``, ``~/.cache/fl_design``.

Examples
--------
>>> from fl_design.codegen import cache_directory
>>> cache_directory("kernels").name
'kernels'
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

from ..errors import CompilationWarning

#: Compiler flags of the kernels (``-fno-math-errno`` only lets ``sqrt`` inline; IEEE kept).
CFLAGS = ("-O3", "-std=c99", "-fno-math-errno", "-fPIC")
#: Strict warning set for exported C (CasADi's generated code and our wrappers compile clean).
STRICT_CFLAGS = ("-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror")
#: Extra flags of kernels built for this machine only (the lanes kernel of the sweeps): its
#: vector instruction set, ``omp simd`` loops without the OpenMP runtime, no floating-point
#: contraction (every operation rounds as in CasADi's interpreter) and no trapping math (lets
#: ``floor`` vectorise; values and NaN propagation unchanged). Still no ``-ffast-math``. The
#: cache key then includes the compiler's view of this CPU (:func:`native_macros`).
NATIVE_CFLAGS = ("-march=native", "-fopenmp-simd", "-ffp-contract=off", "-fno-trapping-math")



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
    >>> from fl_design.codegen import cache_directory
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
    >>> from fl_design.codegen import find_compiler
    >>> find_compiler() is None or os.path.isabs(find_compiler())
    True
    """
    env = os.environ.get("CC")
    for name in [env] if env else ["cc", "gcc", "clang"]:
        path = shutil.which(name)
        if path:
            return path
    return None


@functools.lru_cache(maxsize=4)
def native_macros(compiler: str | None = None) -> frozenset:
    """Macros the compiler predefines with ``-march=native`` (e.g. ``__AVX512F__``).

    Empty when there is no compiler or it does not understand the flag.

    Examples
    --------
    >>> from fl_design.codegen._build import native_macros
    >>> isinstance(native_macros(), frozenset)
    True
    """
    cc = compiler or find_compiler()
    if cc is None:
        return frozenset()
    try:
        proc = subprocess.run([cc, "-march=native", "-dM", "-E", "-x", "c", os.devnull],
                              capture_output=True, text=True, timeout=60, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return frozenset()
    if proc.returncode != 0:
        return frozenset()
    return frozenset(line.split()[1] for line in proc.stdout.splitlines()
                     if line.startswith("#define ") and len(line.split()) > 1)


def generate_source(*functions: ca.Function) -> str:
    """The C source CasADi generates for ``functions`` (no header, no main).

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.codegen import generate_source
    >>> x = ca.SX.sym("x")
    >>> "int twice(" in generate_source(ca.Function("twice", [x], [2 * x]))
    True
    """
    cg = ca.CodeGenerator("fl_kernel.c", {"with_header": False, "verbose": False})
    for fn in functions:
        cg.add(fn)
    return cg.dump()


def build(source: str, name: str, *, shared: bool = True, cache_dir=None,
          compiler: str | None = None, extra_flags: tuple = (), libs: tuple = ()) -> Path | None:
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
    extra_flags, libs : tuple of str, optional
        More compiler flags (e.g. :data:`NATIVE_CFLAGS`) and libraries (``"-lmvec"``); with
        ``-march=native`` the key also holds :func:`native_macros`.

    Examples
    --------
    >>> from fl_design.codegen import build
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
    parts = [source, cc, *flags, ca.__version__]
    if extra_flags or libs:
        parts += [*extra_flags, *libs]
        if "-march=native" in extra_flags:
            parts += sorted(native_macros(cc))
        flags += list(extra_flags)
    key = hashlib.sha256("\n".join(parts).encode()).hexdigest()
    out = cache_directory(cache_dir) / f"{name}_{key[:24]}{'.so' if shared else '.bin'}"
    if out.exists():
        return out
    with tempfile.TemporaryDirectory(dir=out.parent) as tmp:
        c_file, tmp_out = Path(tmp) / f"{name}.c", Path(tmp) / out.name
        c_file.write_text(source)
        try:
            proc = subprocess.run([cc, *flags, str(c_file), "-o", str(tmp_out), *libs, "-lm"],
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




__all__ = ["CFLAGS", "NATIVE_CFLAGS", "STRICT_CFLAGS", "native_macros", "build", "cache_directory", "find_compiler",
           "generate_source"]
