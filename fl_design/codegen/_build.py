"""Compiler calls of the C packages: the strict flag additions, the compiler, a checked command.

The lowest floor of :mod:`fl_design.codegen` (generation -> package -> checks all use it).

Examples
--------
>>> from fl_design.codegen._build import run_command
>>> run_command(["echo", "ok"], what="echo").strip()
'ok'
"""

from __future__ import annotations

import subprocess

from .._toolchain import find_compiler
from ..errors import CompilationError, CompilerNotFoundError

#: extra warnings of every build (prototypes, float equality, any double arithmetic in float)
FLOAT_WARNINGS = ("-Wmissing-prototypes", "-Wfloat-equal", "-Wdouble-promotion",
                  "-Wfloat-conversion")
#: sanitizer flags of :meth:`CPackage.build` with ``sanitize=True``
SANITIZE_FLAGS = ("-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
                  "-fno-sanitize-recover=all")


def compiler_or_raise(compiler: str | None = None) -> str:
    """The C compiler to use, or CompilerNotFoundError saying how to get one.

    Parameters
    ----------
    compiler : str, optional
        Explicit compiler; default :func:`~fl_design.codegen.find_compiler`.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.codegen._build import compiler_or_raise
    >>> compiler_or_raise("cc").endswith("cc")
    True
    """
    cc = compiler or find_compiler()
    if cc is None:
        raise CompilerNotFoundError(
            "no C compiler found: set $CC or install gcc or clang (e.g. apt-get install gcc); "
            "the generated sources are written, but building, verify() and cost() need one")
    return cc


def run_command(cmd: list[str], *, what: str, stdin: str | None = None, cwd=None,
                timeout: float = 600, env=None) -> str:
    """Run ``cmd``; its stdout, or CompilationError with the tail of its stderr.

    Parameters
    ----------
    cmd : list of str
        The command.
    what : str
        What it does, for the error message.
    stdin : str, optional
        Text fed to it.
    cwd : path-like, optional
        Working directory.
    timeout : float, optional
        Seconds; past them a CompilationError says so.
    env : dict, optional
        The environment (default: this process's).

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.codegen._build import run_command
    >>> run_command(["echo", "ok"], what="echo").strip()
    'ok'
    """
    try:
        proc = subprocess.run(cmd, input=stdin, capture_output=True, text=True, cwd=cwd,
                              timeout=timeout, check=False, env=env)
    except FileNotFoundError as exc:
        raise CompilerNotFoundError(f"{what}: {cmd[0]!r} not found ({exc})") from None
    except subprocess.TimeoutExpired:
        raise CompilationError(f"{what}: {cmd[0]} timed out after {timeout:g} s") from None
    if proc.returncode != 0:
        raise CompilationError(
            f"{what} failed (exit {proc.returncode}): {' '.join(cmd)}\n{proc.stderr[-2000:]}")
    return proc.stdout


__all__ = ["FLOAT_WARNINGS", "SANITIZE_FLAGS", "compiler_or_raise", "run_command"]
