"""Small validators shared by every module: each raises an fl_design error naming the value."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .errors import DimensionError, HurwitzError, ParameterError


def real_scalar(name: str, value) -> float:
    """Return ``value`` as a finite float, or raise ParameterError naming it."""
    if isinstance(value, bool):
        raise ParameterError(f"{name} must be a real number, got the bool {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a real number, got {value!r}") from None
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
    """Return a finite 1-D float array, checking its length when given."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a sequence of real numbers, got {value!r}") from None
    if arr.ndim != 1:
        raise DimensionError(f"{name} must be one-dimensional, got shape {arr.shape}")
    if length is not None and arr.shape[0] != length:
        raise DimensionError(f"{name} must have length {length}, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"{name} must be finite, got {arr.tolist()}")
    return arr


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
