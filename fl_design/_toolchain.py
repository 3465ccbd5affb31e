"""C compiler discovery, flag sets and the self-verifying content-hash cache of compiled code.

Every compiled artefact of fl_design (the closed-loop sweep kernel of :mod:`fl_design.sim`, the
exported step of :func:`fl_design.generate_c`) goes through :func:`build` (a program of several
files, the software-in-the-loop driver, through :func:`build_program`): the source is
compiled once with the system C compiler and cached under a name made from the SHA-256 hash
of the source, the compiler command, its flags and the CasADi version, so an unchanged kernel
is never compiled twice (across processes and sessions).

The cache heals itself. Each file is written atomically (temporary name, then
``os.replace``), then a sidecar ``<file>.json`` records its size and SHA-256, also written
atomically, signed with the per-user key kept outside the cache (:func:`fl_design._cache.user_key`).
A cached file is used only when it matches its sidecar and the signature verifies
(:func:`verified`); a truncated, empty, overwritten or planted library (even with a matching
size/SHA-256 sidecar), a missing, disagreeing or unsigned sidecar, is rebuilt. Never
is an unverified file loaded (:mod:`fl_design.sim.kernel._runners` checks again before ``dlopen``).
The directory, sidecars and atomic writes are those of :mod:`fl_design._cache`, shared with the
cache of plant derivations (:mod:`fl_design.symbolic._derivation_cache`).

Cache location, in order: the ``cache_dir`` argument, the environment variable
``$FL_DESIGN_CACHE``, ``$XDG_CACHE_HOME/fl_design``, ``~/.cache/fl_design``. When that
directory cannot be used (read-only, unwritable, a regular file, full disk...), the build
falls back to a private temporary directory (removed at exit), and when that fails too, to
CasADi's interpreter: each fallback says so once with a :class:`~fl_design.errors.CompilationWarning`
(same results, only slower); set ``FL_DESIGN_CACHE`` to a writable directory to keep kernels.

Compiler: ``$CC`` if set, split like a shell word list (``CC='gcc -m64'`` is the compiler
``gcc`` with the flag ``-m64``), else ``cc``, ``gcc`` or ``clang`` on the ``PATH``.

Flag sets: :data:`CFLAGS` (fast, portable: ``-O3``, no ``-march=native``, no
``-ffast-math``, which would break the NaN tests of the divergence detection) and
:data:`STRICT_CFLAGS` (``-std=c99 -pedantic -Wall -Wextra -Werror``, for exported code).

Examples
--------
>>> from fl_design._toolchain import cache_directory
>>> cache_directory("kernels").name
'kernels'
"""

from __future__ import annotations

import atexit
import ctypes
import functools
import hashlib
import json
import os
import platform
import shlex
import shutil
import subprocess
import tempfile
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

import casadi as ca

from ._cache import (
    SIDECAR_SUFFIX,
    cache_directory,
    read_verified,
    replace_text,
    signed_record,
    verified,
)
from ._cache import digest as _digest
from .errors import CompilationWarning, ComputationError

#: Compiler flags of the kernels (``-fno-math-errno`` only lets ``sqrt`` inline; IEEE kept).
CFLAGS = ("-O3", "-std=c99", "-fno-math-errno", "-fPIC")
#: Strict warning set for exported C (CasADi's generated code and our wrappers compile clean).
STRICT_CFLAGS = ("-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror")
#: Extra flags of the lanes kernel of the sweeps (on top of :data:`CFLAGS` and the flags of its
#: instruction-set level, :mod:`fl_design._isa`): ``omp simd`` loops without the OpenMP runtime,
#: no floating-point contraction (every operation rounds as in CasADi's interpreter, whatever
#: the ISA: FMA units change nothing) and no trapping math (lets ``floor`` vectorise; values and
#: NaN propagation unchanged). Still no ``-ffast-math``. With ``-march=native`` the cache key
#: also holds the compiler's view of this CPU (:func:`native_macros`).
LANES_CFLAGS = ("-fopenmp-simd", "-ffp-contract=off", "-fno-trapping-math")

_FALLBACK: dict[str, Path] = {}  # the process's private temporary cache, made on first need


def _compiler() -> tuple[list[str] | None, str]:
    """The compiler command (executable path + flags from ``$CC``) or None and the reason."""
    env = os.environ.get("CC", "").strip()
    if not env:
        for name in ("cc", "gcc", "clang"):
            path = shutil.which(name)
            if path:
                return [path], ""
        return None, "no C compiler found (set $CC or install gcc/clang)"
    try:
        words = shlex.split(env)
    except ValueError as exc:
        return None, f"no C compiler found: $CC={env!r} is not a valid command line ({exc})"
    path = shutil.which(words[0])
    if path is None:
        return None, (f"no C compiler found: $CC={env!r} names {words[0]!r}, which is not an "
                      "executable file or on the PATH; set $CC to an installed compiler "
                      "(flags may follow, e.g. 'gcc -m64') or unset it")
    return [path, *words[1:]], ""


def find_compiler() -> str | None:
    """Path of the C compiler: the first word of ``$CC`` if set, else ``cc``, ``gcc`` or
    ``clang``, else None (flags following the compiler in ``$CC`` are in
    :func:`compiler_command`).

    Examples
    --------
    >>> import os
    >>> from fl_design._toolchain import find_compiler
    >>> find_compiler() is None or os.path.isabs(find_compiler())
    True
    """
    cmd, _ = _compiler()
    return None if cmd is None else cmd[0]


def compiler_command() -> list[str] | None:
    """The compiler as a command: its path then the flags given in ``$CC``, or None.

    ``$CC`` is split like a shell command line: ``CC='gcc -m64'`` gives
    ``['/usr/bin/gcc', '-m64']``.

    Examples
    --------
    >>> import os
    >>> from fl_design._toolchain import compiler_command
    >>> cmd = compiler_command()
    >>> cmd is None or os.path.isabs(cmd[0])
    True
    """
    return _compiler()[0]


def generate_source(*functions: ca.Function) -> str:
    """The C source CasADi generates for ``functions`` (no header, no main).

    Parameters
    ----------
    *functions : casadi.Function
        The functions to generate, each under its own name.

    Returns
    -------
    str
        One C translation unit defining every function.

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design._toolchain import generate_source
    >>> x = ca.SX.sym("x")
    >>> "int twice(" in generate_source(ca.Function("twice", [x], [2 * x]))
    True
    """
    cg = ca.CodeGenerator("fl_kernel.c", {"with_header": False, "verbose": False})
    for fn in functions:
        cg.add(fn)
    return cg.dump()


def _fallback_directory() -> Path:
    if "dir" not in _FALLBACK or not _FALLBACK["dir"].is_dir():
        path = Path(tempfile.mkdtemp(prefix="fl_design-cache-"))
        atexit.register(shutil.rmtree, path, ignore_errors=True)
        _FALLBACK["dir"] = path
    return _FALLBACK["dir"]


class _CompileFailed(Exception):
    pass


def native_macros(compiler: str | None = None) -> frozenset:
    """Macros the compiler predefines with ``-march=native`` (e.g. ``__AVX512F__``).

    Empty when there is no compiler or it does not understand the flag.

    Parameters
    ----------
    compiler : str, optional
        Compiler executable (default :func:`find_compiler`).

    Returns
    -------
    frozenset of str
        The macro names; empty without a compiler.

    Examples
    --------
    >>> from fl_design._toolchain import native_macros
    >>> isinstance(native_macros(), frozenset)
    True
    """
    cc = compiler or find_compiler()
    return frozenset() if cc is None else _native_macros(cc)


@functools.lru_cache(maxsize=4)
def _native_macros(cc: str) -> frozenset:
    """:func:`native_macros` of the compiler ``cc`` (one preprocessor run per process)."""
    try:
        proc = subprocess.run([cc, "-march=native", "-dM", "-E", "-x", "c", os.devnull],
                              capture_output=True, text=True, timeout=60, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return frozenset()
    if proc.returncode != 0:
        return frozenset()
    return frozenset(line.split()[1] for line in proc.stdout.splitlines()
                     if line.startswith("#define ") and len(line.split()) > 1)


def _compile_into(directory: Path, out_name: str, files: dict, cmd: list[str],
                  libs: tuple = ()) -> Path:
    """Compile the ``.c`` files of ``files`` (name -> text, headers beside them) into
    ``directory / out_name`` (atomically) and record the sidecar."""
    out = directory / out_name
    if verified(out):
        return out
    with tempfile.TemporaryDirectory(dir=directory) as tmp:
        for file, text in files.items():
            (Path(tmp) / file).write_text(text)
        units = [file for file in files if file.endswith(".c")]
        try:  # relative names in a fixed folder: the same source gives the same bytes
            proc = subprocess.run([*cmd, *units, "-o", out_name, *libs, "-lm"], cwd=tmp,
                                  capture_output=True, text=True, timeout=900, check=False)
            error = None if proc.returncode == 0 else (proc.stderr.strip() or "failed")
        except subprocess.TimeoutExpired as exc:
            error = str(exc)
        except OSError as exc:
            if not os.path.isdir(tmp):
                raise
            error = str(exc)
        if error is not None:
            raise _CompileFailed(error)
        record = json.dumps(signed_record(out, _digest(Path(tmp) / out_name), directory))
        os.replace(Path(tmp) / out_name, out)
    replace_text(Path(str(out) + SIDECAR_SUFFIX), record)
    return out


class UnverifiedLibrary(ComputationError):
    """A cached library no longer matches the size and SHA-256 recorded when it was built."""


def open_verified(path) -> ctypes.CDLL:
    """``dlopen`` a cached library, only if it matches its recorded, signed size and SHA-256.

    The one rule of every loader of compiled kernels: never load a file that is not the one
    built (a truncated or replaced library could SIGBUS or run someone else's code).

    Raises
    ------
    UnverifiedLibrary
        The file does not match its sidecar (a :class:`~fl_design.errors.ComputationError`).
    OSError
        The dynamic loader refuses it.

    Examples
    --------
    >>> from fl_design._toolchain import UnverifiedLibrary, open_verified
    >>> try:
    ...     open_verified("no-such-library.so")
    ... except UnverifiedLibrary as exc:
    ...     "recorded size and SHA-256" in str(exc)
    True
    """
    if not verified(path):
        raise UnverifiedLibrary(f"the compiled library {path} does not match its recorded size and "
                      "SHA-256")
    return ctypes.CDLL(str(path))


def discard(path) -> None:
    """Remove a cached file and its sidecar (a library that failed to load: rebuilt next time).

    Examples
    --------
    >>> from fl_design._toolchain import discard
    >>> discard("no-such-file.so")
    """
    for p in (Path(path), Path(str(path) + SIDECAR_SUFFIX)):
        try:
            p.unlink()
        except OSError:
            pass


def build(source: str, name: str, *, shared: bool = True, cache_dir=None,
          compiler: str | Sequence[str] | None = None, extra_flags: tuple = (),
          libs: tuple = ()) -> Path | None:
    """Compile ``source`` once (cached by hash, verified); the library/executable path, or None.

    Returns None, with a :class:`~fl_design.errors.CompilationWarning`, when no compiler is
    found, compilation fails, or neither the cache nor a temporary directory can be written.
    A cached file that does not match its recorded size and SHA-256 is rebuilt.

    Parameters
    ----------
    source : str
        C99 source.
    name : str
        Prefix of the file name.
    shared : bool, optional
        Build a shared library (default) or an executable.
    cache_dir : path-like, optional
        See :func:`cache_directory`; falls back to a private temporary directory, with one
        warning, when it cannot be written.
    compiler : str or sequence of str, optional
        Compiler executable, or command with flags; default :func:`compiler_command`.
    extra_flags, libs : tuple of str, optional
        More compiler flags (e.g. :data:`LANES_CFLAGS` and an ISA's) and libraries (``"-lmvec"``); with
        ``-march=native`` the cache key also holds :func:`native_macros`.

    Examples
    --------
    >>> from fl_design._toolchain import build
    >>> build("int one(void) { return 1; }", "one", cache_dir=".").suffix
    '.so'
    """
    if compiler is None:
        cmd, why = _compiler()
    else:
        cmd, why = ([compiler] if isinstance(compiler, str) else list(compiler)), ""
    if cmd is None:
        warnings.warn(f"{why}: {name} runs in CasADi's interpreter, with the same results but "
                      "3-20x slower", CompilationWarning, stacklevel=3)
        return None
    flags = [*CFLAGS, "-shared"] if shared else list(CFLAGS)
    parts = [source, *cmd, *flags, ca.__version__, platform.machine()]
    if extra_flags or libs:
        parts += [*extra_flags, *libs]
        if "-march=native" in extra_flags:
            parts += sorted(native_macros(cmd[0]))
        flags += list(extra_flags)
    key = hashlib.sha256("\n".join(parts).encode()).hexdigest()
    out_name = f"{name}_{key[:24]}{'.so' if shared else '.bin'}"
    problems = []
    for where in (lambda: cache_directory(cache_dir), _fallback_directory):
        try:
            out = _compile_into(where(), out_name, {f"{name}.c": source}, [*cmd, *flags],
                                tuple(libs))
        except _CompileFailed as exc:
            warnings.warn(f"compiling {name} with {shlex.join(cmd)} failed "
                          f"({str(exc)[-400:]}); it runs in CasADi's interpreter, with the same "
                          "results but slower",
                          CompilationWarning, stacklevel=3)
            return None
        except (OSError, ComputationError) as exc:
            problems.append(str(exc.__cause__ or exc))
            continue
        if problems:
            warnings.warn(f"the compiled-kernel cache is unusable ({problems[0]}): {name} is "
                          f"built in the private temporary directory {out.parent} (removed at "
                          "exit); set $FL_DESIGN_CACHE to a writable directory to keep it",
                          CompilationWarning, stacklevel=3)
        return out
    warnings.warn(f"neither the compiled-kernel cache ({problems[0]}) nor a temporary directory "
                  f"({problems[-1]}) can be written: {name} runs in CasADi's interpreter, with "
                  "the same results but slower; set $FL_DESIGN_CACHE to a writable directory",
                  CompilationWarning, stacklevel=3)
    return None


class UnusableCache(ComputationError):
    """Neither the compiled-kernel cache nor a temporary directory can be written
    (:func:`build_program`; the caller may compile where it writes its own files)."""


def build_program(files: Mapping[str, str], name: str, *, flags: Sequence[str],
                  compiler: str | Sequence[str] | None = None, cache_dir=None,
                  libs: Sequence[str] = ()) -> bytes:
    """Compile a program of several files once (cached by their content); its verified bytes.

    Every ``.c`` file of ``files`` is compiled, in the given order, with ``flags`` in a folder
    holding all of them (headers included: give the headers the sources include, with
    ``-I.`` in ``flags``); the executable is cached under the SHA-256 of every file's name
    and text, the compiler command, the flags, the libraries, CasADi's version and the
    architecture, in the self-verifying cache of :func:`build` (or, when that cannot be written,
    the private temporary directory, with one :class:`~fl_design.errors.CompilationWarning`).
    What is returned is the cached file's content after it matched its signed sidecar.

    Parameters
    ----------
    files : mapping of str to str
        File name (no folder) -> text; ``.c`` files are compiled, others are there to be
        included.
    name : str
        Prefix of the cached file's name.
    flags : sequence of str
        The compiler flags (optimization level included).
    compiler : str or sequence of str, optional
        Compiler executable, or command with flags; default :func:`compiler_command`.
    cache_dir : path-like, optional
        See :func:`cache_directory`.
    libs : sequence of str, optional
        Libraries after the sources (``-lm`` is always last).

    Returns
    -------
    bytes
        The executable's bytes (write them where they are to run).

    Raises
    ------
    CompilerNotFoundError
        No compiler.
    CompilationError
        The compiler failed (its messages).
    UnusableCache
        Neither the cache nor a temporary directory can be written (both reasons; a
        :class:`~fl_design.errors.ComputationError`).
    ParameterError
        A file name with a folder or starting with ``.`` or ``-``, or no ``.c`` file.

    Examples
    --------
    >>> from fl_design._toolchain import build_program
    >>> exe = build_program({"one.c": "int main(void) { return 0; }"}, "one", flags=["-O1"],
    ...                     cache_dir=".")
    >>> len(exe) > 0
    True
    """
    from .errors import CompilationError, CompilerNotFoundError, ParameterError

    files = dict(files)
    bad = [f for f in files if not f or Path(f).name != f or f[0] in ".-"]
    if bad or not any(f.endswith(".c") for f in files):
        raise ParameterError(f"files must be plain file names (no folder, not starting with "
                             f"'.' or '-') with at least one .c file, got {sorted(files)!r}")
    if compiler is None:
        cmd, why = _compiler()
        if cmd is None:
            raise CompilerNotFoundError(why)
    else:
        cmd = [compiler] if isinstance(compiler, str) else list(compiler)
    h = hashlib.sha256()
    for part in (*[x for f in files.items() for x in f], *cmd, "|", *flags, "|", *libs,
                 ca.__version__, platform.machine()):
        data = part.encode()
        h.update(len(data).to_bytes(8, "little") + data)
    out_name = f"{name}_{h.hexdigest()[:24]}.bin"
    problems = []
    for where in (lambda: cache_directory(cache_dir), _fallback_directory):
        try:
            out = _compile_into(where(), out_name, files, [*cmd, *flags], tuple(libs))
        except _CompileFailed as exc:
            raise CompilationError(f"compiling {name} failed: {shlex.join([*cmd, *flags])} "
                                   f"{' '.join(files)}\n{str(exc)[-2000:]}") from None
        except (OSError, ComputationError) as exc:
            problems.append(str(exc.__cause__ or exc))
            continue
        data = read_verified(out)
        if data is None:  # changed since it was built: build it again, once, elsewhere
            discard(out)
            problems.append(f"{out} does not match its recorded size and SHA-256")
            continue
        if problems:
            warnings.warn(f"the compiled-kernel cache is unusable ({problems[0]}): {name} is "
                          f"built in the private temporary directory {out.parent} (removed at "
                          "exit); set $FL_DESIGN_CACHE to a writable directory to keep it",
                          CompilationWarning, stacklevel=2)
        return data
    raise UnusableCache(f"{name} cannot be built: neither the compiled-kernel cache "
                        f"({problems[0]}) nor a temporary directory ({problems[-1]}) can be "
                        "written; set $FL_DESIGN_CACHE to a writable directory")


__all__ = [
    "CFLAGS",
    "LANES_CFLAGS",
    "SIDECAR_SUFFIX",
    "STRICT_CFLAGS",
    "UnusableCache",
    "build",
    "build_program",
    "cache_directory",
    "compiler_command",
    "discard",
    "find_compiler",
    "generate_source",
    "native_macros",
    "verified",
]
