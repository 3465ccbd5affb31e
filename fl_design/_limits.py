"""Resource limits that a user can lift with an environment variable: one reader for all.

Work that could exhaust memory or time is refused up front with a
:class:`~fl_design.errors.ResourceLimitError` naming the limit and its variable:
``FL_DESIGN_MAX_SAMPLES`` (samples of one run), ``FL_DESIGN_MAX_MEMORY_GB`` (results of a
grid, records of a run), ``FL_DESIGN_MAX_WINDOW`` (least-squares window),
``FL_DESIGN_MAX_SUBSTEPS`` (RK4 substeps per sample, :data:`MAX_SUBSTEPS`). Every variable is
parsed strictly: a finite positive decimal number, else a clear error naming it (``inf``,
``nan``, ``1e999``, ``banana`` are refused); switches (:func:`env_flag`) are ``0`` or ``1``.
:func:`memory_budget` is the smaller of ``FL_DESIGN_MAX_MEMORY_GB`` (default 4 GiB), the
process's address-space limit (``ulimit -v``) and the memory the system has available.

Examples
--------
>>> from fl_design._limits import env_limit
>>> env_limit("FL_DESIGN_NO_SUCH_LIMIT", 5, unit="samples")
5
"""

from __future__ import annotations

import math
import os
import re

from .errors import ParameterError, ResourceLimitError

_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
#: Default largest number of RK4 substeps per sample. The integrator's work arrays grow with it
#: (a stack of ``substeps * (n + 2)`` doubles in the compiled kernel: 10**6 overflowed the
#: default 8 MiB stack) and so does the time (``substeps`` RK4 steps per sample).
MAX_SUBSTEPS = 10_000
MAX_SUBSTEPS_ENV = "FL_DESIGN_MAX_SUBSTEPS"
MAX_MEMORY_ENV = "FL_DESIGN_MAX_MEMORY_GB"


def env_limit(name: str, default: float, *, unit: str, scale: float = 1.0,
              integer: bool = True):
    """``$name`` (times ``scale``) if set, else ``default``; a bad value is a clear error.

    Parameters
    ----------
    name : str
        Environment variable.
    default : float
        Value when the variable is unset or empty (already scaled).
    unit : str
        What the number counts, for the error message (``"samples"``, ``"GiB"``).
    scale : float, optional
        Factor applied to the variable's value (e.g. ``2**30`` for GiB -> bytes).
    integer : bool, optional
        Return an int (default) or a float.

    Returns
    -------
    int or float

    Raises
    ------
    ParameterError
        The variable is set to something that is not a positive number.

    Examples
    --------
    >>> import os
    >>> from fl_design._limits import env_limit
    >>> os.environ["FL_DOC_LIMIT"] = "2"
    >>> env_limit("FL_DOC_LIMIT", 1.0, unit="GiB", scale=2**30, integer=False)
    2147483648.0
    """
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    value = float(text) * scale if _DECIMAL.fullmatch(text) else math.nan
    if not (value > 0 and math.isfinite(value)) or (integer and value < 1):
        raise ParameterError(f"${name}={text!r} must be a positive number of {unit}, finite "
                             f"and in decimal (e.g. {name}={default / scale:g}), or unset for "
                             "the default")
    return int(value) if integer else value


def env_flag(name: str, default: bool) -> bool:
    """A switch ``$name``: ``1`` (on) or ``0`` (off); unset or empty gives ``default``.

    Parameters
    ----------
    name : str
        The variable's name, without ``$``.
    default : bool

    Returns
    -------
    bool

    Raises
    ------
    ParameterError
        Any other value (``banana``, ``yes``, ``2``).

    Examples
    --------
    >>> import os
    >>> from fl_design._limits import env_flag
    >>> os.environ["FL_DOC_FLAG"] = "0"
    >>> env_flag("FL_DOC_FLAG", True)
    False
    """
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    if text not in ("0", "1"):
        raise ParameterError(f"${name}={text!r} must be 0 (off) or 1 (on), or unset for the "
                             f"default ({int(default)})")
    return text == "1"


def _available_bytes() -> float:
    """The system's available memory (``MemAvailable``), or inf when unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        pass
    return math.inf


def memory_budget() -> tuple[float, str]:
    """Bytes one computation may allocate, and what sets that bound.

    The smallest of ``$FL_DESIGN_MAX_MEMORY_GB`` (default 4 GiB), the address-space limit
    (``ulimit -v``) and the available memory.

    Returns
    -------
    (float, str)
        The bytes, and which of the three bounds set them (in words).

    Examples
    --------
    >>> from fl_design._limits import memory_budget
    >>> budget, why = memory_budget()
    >>> budget > 0 and isinstance(why, str)
    True
    """
    options = [(env_limit(MAX_MEMORY_ENV, 4.0 * 2**30, unit="GiB", scale=2**30, integer=False),
                f"${MAX_MEMORY_ENV}")]
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft not in (resource.RLIM_INFINITY, -1) and soft > 0:
            options.append((float(soft), "the process's address-space limit (ulimit -v)"))
    except (ImportError, OSError, ValueError):
        pass
    options.append((_available_bytes(), "the system's available memory"))
    return min(options, key=lambda o: o[0])


def check_memory(need: float, what: str, fix: str) -> None:
    """Refuse up front (ResourceLimitError) when ``need`` bytes exceed :func:`memory_budget`.

    Parameters
    ----------
    need : float
        Bytes the work would allocate.
    what : str
        The work, for the message (``"a run of 3e+07 samples"``).
    fix : str
        How to make it smaller (``"shorten the run"``).

    Examples
    --------
    >>> from fl_design._limits import check_memory
    >>> check_memory(1e3, "a tiny run", "none needed")
    >>> check_memory(1e30, "a huge run", "shorten it")
    Traceback (most recent call last):
    ...
    fl_design.errors.ResourceLimitError: a huge run needs about 9.31e+20 GiB, above ...
    """
    budget, why = memory_budget()
    if need > budget:
        raise ResourceLimitError(
            f"{what} needs about {need / 2**30:.3g} GiB, above {budget / 2**30:.3g} GiB "
            f"({why}); {fix}, or raise the limit with ${MAX_MEMORY_ENV} if the memory exists")


def check_substeps(value) -> int:
    """``value`` as RK4 substeps: an integer in ``[1, $FL_DESIGN_MAX_SUBSTEPS]``.

    Parameters
    ----------
    value : int
        RK4 steps per sample, as the caller gave it.

    Returns
    -------
    int
        ``value`` as an ``int``, within the limit.

    Raises
    ------
    ParameterError
        Not a positive integer.
    ResourceLimitError
        Above the limit (default :data:`MAX_SUBSTEPS`).

    Examples
    --------
    >>> from fl_design._limits import check_substeps
    >>> check_substeps(8)
    8
    """
    from . import _validate as V

    n = V.integer("substeps", value, minimum=1)
    limit = env_limit(MAX_SUBSTEPS_ENV, MAX_SUBSTEPS, unit="substeps")
    if n > limit:
        raise ResourceLimitError(
            f"substeps={n} is above the limit of {limit} RK4 steps per sample (each sample "
            f"would cost {n} steps and a work array of {n} states); use a shorter sampling "
            f"time T or fewer substeps, or raise the limit with ${MAX_SUBSTEPS_ENV}")
    return n


__all__ = ["MAX_SUBSTEPS", "check_memory", "check_substeps", "env_flag", "env_limit",
           "memory_budget"]
