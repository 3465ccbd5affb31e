"""Small validators shared by every module: each raises an fl_design error naming the value."""

from __future__ import annotations

import math
import numbers
import reprlib
from collections.abc import Sequence

import numpy as np

from .errors import DimensionError, HurwitzError, ParameterError

_REPR = reprlib.Repr()
_REPR.maxstring, _REPR.maxother, _REPR.maxlist, _REPR.maxtuple = 40, 40, 6, 6


def short(value) -> str:
    """A repr of ``value`` cut to a few dozen characters (for error messages).

    Examples
    --------
    >>> from fl_design._validate import short
    >>> short(list(range(100)))
    '[0, 1, 2, 3, 4, 5, ...]'
    """
    if isinstance(value, np.ndarray):
        return f"array of shape {value.shape} and dtype {value.dtype}"
    if isinstance(value, np.generic):
        value = value.item()
    return _REPR.repr(value)


def is_real_number(value) -> bool:
    """True for a real number: int, float, NumPy integer/float scalar or 0-d array, Fraction...;
    False for bools, strings and everything else (no silent conversion).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design._validate import is_real_number
    >>> is_real_number(np.float32(0.5)), is_real_number("0.5"), is_real_number(True)
    (True, False, False)
    """
    if isinstance(value, (bool, np.bool_)):
        return False
    if isinstance(value, np.ndarray):
        return value.ndim == 0 and value.dtype.kind in "iuf"
    return isinstance(value, numbers.Real)


def real_scalar(name: str, value) -> float:
    """Return ``value`` as a finite float, or raise ParameterError naming it."""
    if isinstance(value, (bool, np.bool_)):
        raise ParameterError(f"{name} must be a real number, got the bool {value!r}")
    if not is_real_number(value):
        raise ParameterError(f"{name} must be a real number, got {short(value)} (a "
                             f"{type(value).__name__}; give an int or a float)")
    try:
        out = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(f"{name} must be a real number, got {short(value)}") from None
    if not math.isfinite(out):
        raise ParameterError(f"{name} must be finite, got {out!r}")
    return out


def boolean(name: str, value) -> bool:
    """Return ``value`` if it is a bool (NumPy bools too), else raise ParameterError naming it."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise ParameterError(f"{name} must be True or False, got {value!r}")


def positive(name: str, value) -> float:
    """Return ``value`` as a finite float > 0, or raise ParameterError naming it."""
    out = real_scalar(name, value)
    if out <= 0.0:
        raise ParameterError(f"{name} must be > 0, got {out!r}")
    return out


def nonzero(name: str, value) -> float:
    """Return ``value`` as a finite float != 0, or raise ParameterError naming it."""
    out = real_scalar(name, value)
    if out == 0.0:
        raise ParameterError(f"{name} must be nonzero (its sign is that of b), got {out!r}")
    return out


def nonnegative(name: str, value) -> float:
    """Return ``value`` as a finite float >= 0, or raise ParameterError naming it."""
    out = real_scalar(name, value)
    if out < 0.0:
        raise ParameterError(f"{name} must be >= 0, got {out!r}")
    return out


def integer(name: str, value, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """Return ``value`` as an int within [minimum, maximum], or raise ParameterError."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name} must be an integer, got {value!r}")
    out = int(value)
    if minimum is not None and out < minimum:
        raise ParameterError(f"{name} must be >= {minimum}, got {out}")
    if maximum is not None and out > maximum:
        raise ParameterError(f"{name} must be <= {maximum}, got {out}")
    return out


def real_vector(name: str, value, *, length: int | None = None) -> np.ndarray:
    """Return a finite 1-D float array, checking its length when given.

    Entries must be real numbers (strings and bools are refused, not converted); messages
    name the first bad entry and the length, never the whole array.
    """
    if isinstance(value, (str, bytes)):
        raise ParameterError(f"{name} must be a sequence of real numbers, got the string "
                             f"{short(value)}")
    if isinstance(value, (list, tuple)):  # NumPy would turn True into 1 and 2.0 into '2.0'
        for i, x in enumerate(value):
            if type(x) is float or type(x) is int or isinstance(x, (list, tuple, np.ndarray)):
                continue  # nested sequences: the shape check below speaks
            if not is_real_number(x):
                raise ParameterError(f"{name} must be a sequence of real numbers (int or float)"
                                     f": entry {i} is {short(x)} ({len(value)} entries)")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a sequence of real numbers, got {short(value)}"
                             ) from None
    if raw.dtype.kind not in "iuf":
        flat = raw.reshape(-1)
        bad = next((i for i, v in enumerate(flat) if not is_real_number(v)), None)
        if bad is not None or raw.dtype.kind not in "O":
            where = "" if bad is None else f": entry {bad} is {short(flat[bad])}"
            raise ParameterError(f"{name} must be a sequence of real numbers (int or float)"
                                 f"{where} ({raw.size} entries, dtype {raw.dtype})")
    try:
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(f"{name} must be a sequence of real numbers, got {short(value)}"
                             ) from None
    if arr.ndim != 1:
        raise DimensionError(f"{name} must be one-dimensional, got shape {arr.shape}")
    if length is not None and arr.shape[0] != length:
        raise DimensionError(f"{name} must have length {length}, got {arr.shape[0]}")
    finite = np.isfinite(arr)
    if not finite.all():
        first = int(np.argmin(finite))
        raise ParameterError(f"{name} must be finite: entry {first} is {short(arr[first])} "
                             f"({int(arr.size - finite.sum())} non-finite of {arr.size} entries)")
    return arr


def instance(name: str, value, cls, what: str):
    """Return ``value`` if it is an instance of ``cls``, else raise ParameterError naming both.

    Parameters
    ----------
    name : str
        The argument's name.
    value : object
        What was given.
    cls : type or tuple of types
        Accepted classes.
    what : str
        What is expected, in words (e.g. ``"a Plant (fl.Plant.from_ode or fl.plants.*)"``).

    Returns
    -------
    object
        ``value``, unchanged.

    Examples
    --------
    >>> from fl_design._validate import instance
    >>> instance("order", 3, int, "an int")
    3
    >>> instance("plant", "trms", int, "a Plant")
    Traceback (most recent call last):
    ...
    fl_design.errors.ParameterError: plant must be a Plant, got str 'trms'
    """
    if isinstance(value, cls):
        return value
    raise ParameterError(f"{name} must be {what}, got {type(value).__name__} {short(value)}")


def interval(name: str, value, *, allow_none: bool = True) -> tuple[float, float] | None:
    """Return ``(lo, hi)`` with lo < hi (a scalar c > 0 means ``(-c, c)``), or None."""
    if value is None:
        if allow_none:
            return None
        raise ParameterError(f"{name} must be an interval (lo, hi), got None")
    if np.ndim(value) == 0:
        c = positive(name, value)
        return (-c, c)
    if not isinstance(value, (Sequence, np.ndarray)) or len(value) != 2:
        raise DimensionError(f"{name} must be (lo, hi) or a positive scalar c, got {value!r}")
    lo = real_scalar(f"{name}[0]", value[0])
    hi = real_scalar(f"{name}[1]", value[1])
    if not lo < hi:
        raise ParameterError(f"{name} must satisfy lo < hi, got ({lo}, {hi}) (reversed or empty)")
    return (lo, hi)


def hurwitz_monic(name: str, coeffs_high_to_low: np.ndarray, *, what: str) -> np.ndarray:
    """Check that the monic polynomial ``s^n + c[0] s^(n-1) + ... + c[n-1]`` is Hurwitz.

    Returns its roots. Raises HurwitzError listing the roots with non-negative real part.
    """
    roots = np.roots(np.concatenate([[1.0], np.asarray(coeffs_high_to_low, dtype=float)]))
    bad = roots[roots.real >= 0.0]
    if bad.size:
        shown = ", ".join(
            f"{r.real:.6g}" if abs(r.imag) < 1e-12 else f"{r.real:.6g}{r.imag:+.6g}j" for r in bad
        )
        raise HurwitzError(
            f"{name}={np.asarray(coeffs_high_to_low, dtype=float).tolist()} give {what} with roots "
            f"not in the open left half-plane: {shown}; choose coefficients whose polynomial is "
            "Hurwitz (e.g. binomial coefficients, all roots at -1)"
        )
    return roots


def identifier(name: str, value) -> str:
    """Return ``value`` if it is a name (letters, digits, ``_``; not a keyword), else raise.

    Examples
    --------
    >>> from fl_design._validate import identifier
    >>> identifier("states", "theta")
    'theta'
    """
    import keyword

    if isinstance(value, str) and value.isidentifier() and not keyword.iskeyword(value):
        return value
    raise ParameterError(f"{name} must be a name (letters, digits, _; not starting with a "
                         f"digit), got {short(value)}")


def choice(name: str, value, options: Sequence[str]):
    """Return ``value`` if it is one of ``options``, else raise ParameterError listing them.

    Examples
    --------
    >>> from fl_design._validate import choice
    >>> choice("precision", "float", ("double", "float"))
    'float'
    """
    if isinstance(value, str) and value in options:
        return value
    raise ParameterError(f"{name} must be one of {', '.join(map(repr, options))}, got "
                         f"{short(value)}")


def real_tuple(name: str, value, *, length: int | None = None, positive_only: bool = False,
            nonempty: bool = False) -> tuple[float, ...]:
    """Return a tuple of finite floats (:func:`real_vector`), optionally all > 0 or non-empty.

    Examples
    --------
    >>> from fl_design._validate import real_tuple
    >>> real_tuple("gains", [2, 4.0])
    (2.0, 4.0)
    """
    out = tuple(float(v) for v in real_vector(name, value, length=length))
    if nonempty and not out:
        raise ParameterError(f"{name} must hold at least one number, got an empty array")
    bad = [v for v in out if v <= 0] if positive_only else []
    if bad:
        raise ParameterError(f"{name} must hold positive numbers, got {bad[0]!r} in {short(value)}")
    return out


def log_range(name: str, value, *, sign: float | None = None) -> tuple[float, float]:
    """A ``[lo, hi]`` range of one sign for a log-spaced grid: ``0 < lo < hi`` by default;
    ``sign=-1`` or ``+1``: both ends of that sign; ``sign=0``: either sign, not containing 0.

    Examples
    --------
    >>> from fl_design._validate import log_range
    >>> log_range("eps", [0.01, 1])
    (0.01, 1.0)
    >>> log_range("gamma", [-1e-2, -1e-4], sign=0)
    (-0.01, -0.0001)
    """
    lo, hi = real_tuple(name, value, length=2)
    if not lo < hi:
        raise ParameterError(f"{name} must be [lo, hi] with lo < hi, got {short(value)}")
    if sign is None and lo <= 0:
        raise ParameterError(f"{name} must hold positive numbers (s), got {short(value)}")
    if sign is not None and (lo * hi <= 0 or (sign and lo * sign < 0)):
        which = "" if not sign else f" and be {'negative' if sign < 0 else 'positive'}"
        raise ParameterError(f"{name} must not contain 0{which}, got {short(value)}")
    return lo, hi
