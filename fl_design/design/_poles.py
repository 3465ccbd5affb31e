"""Pole lists: validated once, turned into monic-polynomial coefficients in closed form.

Both the controller gains (:func:`fl_design.gains_from_poles`) and the observer coefficients
(:meth:`fl_design.EHGO.from_poles`) come from ``prod_i (s - p_i)``: repeated poles are exact
(never a pole-placement routine).

Examples
--------
>>> from fl_design.design._poles import checked_poles, monic_coefficients
>>> monic_coefficients(checked_poles([-1, -2, -3]))
(6.0, 11.0, 6.0)
"""

from __future__ import annotations

import numpy as np

from ..errors import DimensionError, HurwitzError, ParameterError


def checked_poles(poles, *, count: int | None = None, what: str = "") -> np.ndarray:
    """``poles`` as a complex array: numbers, finite, left half-plane, conjugate-closed.

    Parameters
    ----------
    poles : sequence of complex
        The poles.
    count : int, optional
        Required number of poles.
    what : str, optional
        Context for the length error (e.g. ``"rho+1 = 3"``).

    Returns
    -------
    numpy.ndarray
        The poles as complex numbers, in the given order.

    Raises
    ------
    ParameterError
        Not numbers, non-finite, or a complex pole without its conjugate.
    DimensionError
        Empty, not 1-D, or not ``count`` poles.
    HurwitzError
        A pole with a non-negative real part (the observer and the closed loop must be
        Hurwitz: roots in the open left half-plane).

    Examples
    --------
    >>> from fl_design.design._poles import checked_poles
    >>> checked_poles([-1 + 2j, -1 - 2j]).tolist()
    [(-1+2j), (-1-2j)]
    """
    try:
        p = np.atleast_1d(np.asarray(poles, dtype=complex))
    except (TypeError, ValueError):
        raise ParameterError(f"poles must be a sequence of numbers, got {poles!r}") from None
    if p.ndim != 1 or p.size == 0:
        raise DimensionError(f"poles must be a non-empty 1-D sequence, got {poles!r}")
    if count is not None and p.size != count:
        raise DimensionError(f"poles must be a sequence of {what or count} numbers, "
                             f"got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ParameterError(f"poles must be finite, got {p.tolist()}")
    if np.any(p.real >= 0.0):
        raise HurwitzError(
            f"poles must have negative real parts (roots in the open left half-plane), got "
            f"{p[p.real >= 0.0].tolist()}")
    scale = max(1.0, float(np.max(np.abs(p))))
    unmatched = list(p[np.abs(p.imag) > 1e-12 * scale])
    while unmatched:
        first = unmatched.pop(0)
        dist = [abs(q - np.conj(first)) for q in unmatched]
        if not dist or min(dist) > 1e-9 * scale:
            raise ParameterError(
                f"complex poles must come in conjugate pairs: {first} has no partner "
                f"{np.conj(first)} in {p.tolist()}")
        unmatched.pop(int(np.argmin(dist)))
    return p


def monic_coefficients(poles: np.ndarray) -> tuple[float, ...]:
    """``(c_1, ..., c_n)`` of ``prod_i (s - p_i) = s^n + c_1 s^(n-1) + ... + c_n``.

    Parameters
    ----------
    poles : numpy.ndarray
        Validated poles (:func:`checked_poles`).

    Returns
    -------
    tuple of float
        Real coefficients (the poles are conjugate-closed).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.design._poles import monic_coefficients
    >>> monic_coefficients(np.array([-1.0, -1.0]))
    (2.0, 1.0)
    """
    coeffs = np.array([1.0 + 0.0j])
    for pole in poles:  # multiply by (s - pole)
        coeffs = np.append(coeffs, 0.0) - pole * np.insert(coeffs, 0, 0.0)
    return tuple(float(c) for c in coeffs.real[1:])


__all__ = ["checked_poles", "monic_coefficients"]
