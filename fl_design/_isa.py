"""Which vector instruction set the compiled sweep kernel uses on this machine, and why.

The lanes kernel of the sweeps (:mod:`fl_design.sim.kernel._lanes`) runs ``W`` grid points per SIMD
register. Nothing about the machine is assumed: the levels this CPU supports are read at run
time from the C compiler's view of it (the macros ``-march=native`` predefines: the compiler
asks the CPU with ``cpuid`` on x86-64), and one level is chosen:

=========  =====  ===========================================  ======================
level      W      flags (on top of the kernel flags)           libmvec variant
=========  =====  ===========================================  ======================
avx512     8      ``-march=native``                            ``_ZGVeN8v_*``
avx2       4      ``-march=native -mno-avx512f``               ``_ZGVdN4v_*``
sse2       2      ``-march=native -mno-avx``                   ``_ZGVbN2v_*``
neon       2      ``-march=native`` (aarch64)                  ``_ZGVnN2v_*``
portable   2      none (any other CPU the compiler targets)    none
scalar     1      the scalar compiled kernel, one run a time   none
=========  =====  ===========================================  ======================

The default is the widest level available. ``FL_DESIGN_ISA`` (or ``fl.Kernel(isa=...)``,
which wins) forces a narrower one, so every path can be tested and timed on one machine; a
level the CPU lacks is refused with the list of those it has (never a SIGILL). The chosen
level's flags, and with ``-march=native`` the compiler's macros for this CPU, are part of the
compiled kernel's cache key, so a kernel built for another CPU (a cache folder shared over
NFS) is never loaded.

Examples
--------
>>> from fl_design._isa import available_isas, resolve_isa
>>> isa = resolve_isa("scalar")
>>> isa.name, isa.width
('scalar', 1)
>>> "scalar" in available_isas()
True
"""

from __future__ import annotations

import ctypes
import functools
import os
import platform
from dataclasses import dataclass

from ._toolchain import find_compiler, native_macros
from .errors import ParameterError

#: Environment variable forcing an instruction-set level (see the module docstring).
ISA_ENV = "FL_DESIGN_ISA"


@dataclass(frozen=True)
class Isa:
    """One instruction-set level of the lanes kernel.

    Parameters
    ----------
    name : str
        ``avx512``, ``avx2``, ``sse2``, ``neon``, ``portable`` or ``scalar``.
    width : int
        Doubles per vector (lanes); 1 for the scalar kernel.
    flags : tuple of str
        Compiler flags selecting it.
    mvec : str or None
        Letter of glibc libmvec's vector-function variant (``e``, ``d``, ``b``, ``n``).
    requires : str or None
        Macro ``-march=native`` must predefine for this CPU to run it.

    Examples
    --------
    >>> from fl_design._isa import LEVELS
    >>> LEVELS["avx2"].width
    4
    """

    name: str
    width: int
    flags: tuple[str, ...]
    mvec: str | None
    requires: str | None

    @property
    def lanes(self) -> bool:
        """True when the lanes kernel runs (False for ``scalar``)."""
        return self.width > 1


#: Every level fl_design knows, widest first per architecture.
LEVELS = {
    "avx512": Isa("avx512", 8, ("-march=native",), "e", "__AVX512F__"),
    "avx2": Isa("avx2", 4, ("-march=native", "-mno-avx512f"), "d", "__AVX2__"),
    "sse2": Isa("sse2", 2, ("-march=native", "-mno-avx"), "b", "__SSE2__"),
    "neon": Isa("neon", 2, ("-march=native",), "n", "__ARM_NEON"),
    "portable": Isa("portable", 2, (), None, None),
    "scalar": Isa("scalar", 1, (), None, None),
}


def available_isas(compiler: str | None = None) -> tuple[str, ...]:
    """Levels this machine can run, widest first (``scalar`` is always there).

    Parameters
    ----------
    compiler : str, optional
        Compiler executable (default :func:`fl_design._toolchain.find_compiler`).

    Returns
    -------
    tuple of str
        Level names from :data:`LEVELS` (``avx512``, ``avx2``, ...), ``scalar`` last.

    Examples
    --------
    >>> from fl_design._isa import available_isas
    >>> available_isas()[-1]
    'scalar'
    """
    cc = compiler or find_compiler()
    if cc is None:
        return ("scalar",)
    macros = native_macros(cc)
    found = [name for name, isa in LEVELS.items()
             if isa.requires is not None and isa.requires in macros]
    if "__x86_64__" in macros:
        found = [n for n in found if n in ("avx512", "avx2", "sse2")]
    elif "__aarch64__" in macros:
        found = [n for n in found if n == "neon"]
    else:
        found = []
    if not found:
        found = ["portable"]
    return (*found, "scalar")


def _requested(isa: str | None) -> tuple[str | None, str]:
    if isa is not None:
        return isa, "fl.Kernel(isa=...)"
    env = os.environ.get(ISA_ENV)
    if env is not None and env.strip():
        return env, f"${ISA_ENV}"
    return None, "widest available"


def resolve_isa(isa: str | None = None, compiler: str | None = None) -> Isa:
    """The level to build for: ``isa``, else ``$FL_DESIGN_ISA``, else the widest available.

    ``"native"`` means the widest available.

    Parameters
    ----------
    isa : str, optional
        A level name (see :data:`LEVELS`) or ``"native"``.
    compiler : str, optional
        Compiler executable.

    Returns
    -------
    Isa

    Raises
    ------
    ParameterError
        An unknown name, or a level this CPU (as its compiler sees it) cannot run.

    Examples
    --------
    >>> from fl_design._isa import resolve_isa
    >>> resolve_isa("native").width >= 1
    True
    """
    name, source = _requested(isa)
    have = available_isas(compiler)
    if name is None:
        return LEVELS[have[0]]
    if not isinstance(name, str):
        raise ParameterError(f"isa must be a string naming an instruction-set level, got "
                             f"{name!r}; choose one of {', '.join(have)} (or 'native')")
    key = name.strip().lower()
    if key == "native":
        return LEVELS[have[0]]
    if key not in LEVELS:
        raise ParameterError(f"{source} = {name!r} is not an instruction-set level; valid: "
                             f"{', '.join(LEVELS)} or 'native' (this machine: "
                             f"{', '.join(have)})")
    if key not in have:
        raise ParameterError(f"{source} = {name!r} is not available on this machine "
                             f"({cpu_model()}, {platform.machine()}); choose one of "
                             f"{', '.join(have)} (or 'native')")
    return LEVELS[key]


@functools.lru_cache(maxsize=16)
def mvec_functions(isa: Isa, names: tuple[str, ...]) -> tuple[str, ...]:
    """Those of ``names`` with a libmvec vector version for ``isa`` on this machine.

    Parameters
    ----------
    isa : Isa
        The level (its lane width and variant letter).
    names : tuple of str
        C math function names (``sin``, ``tanh``...).

    Returns
    -------
    tuple of str
        Sorted; empty without glibc's libmvec or for levels without a variant.

    Examples
    --------
    >>> from fl_design._isa import LEVELS, mvec_functions
    >>> mvec_functions(LEVELS["scalar"], ("sin",))
    ()
    """
    if isa.mvec is None:
        return ()
    try:
        lib = ctypes.CDLL("libmvec.so.1")
    except OSError:
        return ()
    return tuple(sorted(n for n in set(names)
                        if hasattr(lib, f"_ZGV{isa.mvec}N{isa.width}v_{n}")))


@functools.lru_cache(maxsize=1)
def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``, else :func:`platform.processor`).

    Examples
    --------
    >>> from fl_design._isa import cpu_model
    >>> isinstance(cpu_model(), str)
    True
    """
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.lower().startswith(("model name", "cpu model", "hardware")):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


__all__ = ["ISA_ENV", "LEVELS", "Isa", "available_isas", "cpu_model", "mvec_functions",
           "resolve_isa"]
