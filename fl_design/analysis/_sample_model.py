"""Sample-map models of the LDI (:mod:`._ldi`): interval ZOH box, first- and second-order.

The interval ZOH model (Metzler comparison) and the first-order model with its remainder are
argued in :mod:`._ldi`'s docstring; this module adds the second-order model below and holds all
three (:func:`_sample_maps` picks one).

**Setting** (as :mod:`._ldi`). Over one sample, with ``u`` held, the augmented state
``z = (xi, u)`` obeys ``z' = (X_c + D(t)) z``: ``X_c`` the centre of the vertex matrices and
``D(t) = e_r d(t)^T`` nonzero only in the row ``r = rho - 1`` (the chain's last row, the
deviation ``d(t) = (a(t) - a_c, b(t) - b_c)`` of the slopes and ``b`` from the box's centre),
``d(t)`` anywhere in the centred box ``B`` (half-widths ``dbar``), varying in time.

**Model.** With ``E(t) = expm(t X_c)``, variation of constants gives the transition

    Psi = E(T) + int_0^T E(T - s) D(s) E(s) ds + (terms with two or more D's)

and, expanding ``E(T - s) e_r = e_r + (T - s) X_c e_r + G(T - s)``, ``E(s) = I + H(s)``::

    Psi = E(T) + T e_r dbar_1^T + (T^2 / 2) X_c e_r dbar_2^T + R

with ``dbar_1 = (1/T) int d``, ``dbar_2 = (2/T^2) int (T - s) d(s) ds``: two weighted time
averages of ``d``. ``dbar_1`` is inside ``B`` (a convex set) and the two differ by
``dbar_2 - dbar_1 = int w(s) d(s) ds`` with ``w = (T - 2 s)/T^2``, ``int |w| = 1/2``: inside
``B / 2``. The model is affine in ``(dbar_1, dbar_2 - dbar_1)`` over ``B x B/2``, so the
sample maps whose loops must contract are its values at the **pairs** (a corner of ``B``, a
corner of ``B/2``) (``4^k`` maps, ``k`` the varying entries; with ``dbar_2 = dbar_1`` the
corners' own maps, their exact ZOH up to the remainder, on which the LMI is posed). The first-order
model of :mod:`._ldi` (``E(T) + T D(dbar_1)``) puts the ``T^2 / 2`` term (``b``'s effect on
the position within a sample, and the slopes') into its remainder with absolute values, which
the observer's high gains amplify (at ``eps = 2 T`` it exceeded the contraction tenfold);
here it is polytopic, signs kept.

**Remainder** (entrywise, ``A = |X_c|``, ``Dbar = e_r dbar^T``, ``Ehat(t) = expm(t A)``, the
majorant of ``|E(t)|``; every integral of matrix exponentials by Van Loan's block exponential)::

    |R| <= [expm(T (A + Dbar)) - Ehat(T) - int Ehat(T - s) Dbar Ehat(s) ds]    (>= 2 D's)
         + (int_0^T Ehat(t) dt - T I - T^2/2 A) Dbar                         (G, |G(t)| <= (Ehat(t) - I - t A) e_r)
         + int Ehat(T - s) Dbar (Ehat(s) - I) ds                              (H)

each moved up by ``64 ulp`` of its operands for rounding. It is ``O(T^2 |d|)`` in the rows the
model already carries to that order, ``O(T^3)`` elsewhere: on the slope box of the benchmark
(``b in [1, 5]``, slopes ``+-0.2``, ``+-0.1``, ``T = 1 ms``) ``2.5e-7`` against ``1e-6``.

Examples
--------
>>> import numpy as np
>>> Xs = np.array([[[0, 1, 0], [a, 0, b], [0, 0, 0]] for a in (-1.0, 1.0) for b in (1.0, 2.0)])
>>> m = second_order_maps(Xs, 1e-3, 2)
>>> len(m.lmi), len(m.pairs), bool(np.all(m.Rbar >= 0))
(4, 16, True)
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import scipy.linalg

#: Most corner pairs checked (``4^k``); above it :mod:`._ldi` keeps the first-order model.
MAX_PAIRS = 4096
#: Most corners of the interval ZOH model (else the first-order model is used).
MAX_BOX_CORNERS = 256


def van_loan(A, B, C, T: float) -> np.ndarray:
    """``int_0^T expm((T - s) A) B expm(s C) ds`` (Van Loan's block exponential).

    Examples
    --------
    >>> import numpy as np
    >>> round(float(van_loan(np.zeros((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), 2.0)[0, 0]), 12)
    2.0
    """
    n = A.shape[0]
    Z = np.zeros((2 * n, 2 * n))
    Z[:n, :n], Z[:n, n:], Z[n:, n:] = A, B, C
    return scipy.linalg.expm(T * Z)[:n, n:]


@dataclass(frozen=True)
class SecondOrderMaps:
    """The second-order model's sample maps (see the module docstring).

    Parameters
    ----------
    lmi : list of numpy.ndarray
        One map per corner (``dbar_1 = dbar_2`` = the corner; its exact ZOH up to ``Rbar``):
        what the LMI is posed on.
    pairs : list of numpy.ndarray
        Every pair (corner of ``B`` for ``dbar_1``, corner of ``B/2`` for
        ``dbar_2 - dbar_1``): what the NumPy re-check covers.
    Rbar : numpy.ndarray
        Entrywise bound of the remainder.
    """

    lmi: list
    pairs: list
    Rbar: np.ndarray


def second_order_maps(Xs, T: float, rho: int) -> SecondOrderMaps | None:
    """The second-order model of the sample maps of the vertex matrices ``Xs``, or None.

    None when the vertices differ outside the row ``rho - 1`` (not a chain's slope box) or
    there are more than :data:`MAX_PAIRS` corner pairs.

    Parameters
    ----------
    Xs : array_like, shape (V, rho + 1, rho + 1)
        The vertex matrices of ``z' = X z`` (every corner of the slope box x b range).
    T : float
        Sampling time.
    rho : int
        Relative degree (the varying row is ``rho - 1``).

    Returns
    -------
    SecondOrderMaps or None
    """
    Xs = np.asarray(Xs, dtype=float)
    Xc = 0.5 * (np.max(Xs, axis=0) + np.min(Xs, axis=0))
    r, n = rho - 1, Xc.shape[0]
    dev = Xs - Xc
    others = np.delete(dev, r, axis=1)
    if np.any(others != 0.0) or len(Xs) ** 2 > MAX_PAIRS:
        return None
    ds = dev[:, r, :]
    dbar = np.max(np.abs(ds), axis=0)
    T = float(T)
    E = scipy.linalg.expm(T * Xc)
    e_r = np.zeros(n)
    e_r[r] = 1.0
    c2 = Xc @ e_r
    first = [E + T * np.outer(e_r, d) for d in ds]
    lmi = [f + 0.5 * T * T * np.outer(c2, d) for f, d in zip(first, ds)]
    pairs = [lmi[i] + 0.25 * T * T * np.outer(c2, ds[j])
             for i, j in itertools.product(range(len(ds)), repeat=2)]
    A, Dbar, eye, zero = np.abs(Xc), np.outer(e_r, dbar), np.eye(n), np.zeros((n, n))
    big = scipy.linalg.expm(T * (A + Dbar))
    Ehat = scipy.linalg.expm(T * A)
    once = van_loan(A, Dbar, A, T)
    two = big - Ehat - once
    g = (van_loan(A, eye, zero, T) - T * eye - 0.5 * T * T * A) @ Dbar
    once0 = van_loan(A, Dbar, zero, T)
    h = once - once0
    ulp = 64.0 * np.finfo(float).eps
    pad = ulp * (np.abs(big) + np.abs(Ehat) + np.abs(once)) * ((big != Ehat) | (once != 0.0))
    pad += ulp * (T * np.abs(Dbar) + np.abs(once) + np.abs(once0))
    Rbar = np.maximum(two, 0.0) + np.maximum(g, 0.0) + np.maximum(h, 0.0) + pad
    return SecondOrderMaps(lmi, pairs, Rbar)


def _remainder_bound(Xs, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Center ``X_c`` and an entrywise bound of ``Psi - expm(T X_c) - T (X(thetabar) - X_c)``.

    With ``X(t) = X_c + D(t)``, ``|D(t)| <= Dbar`` entrywise, the Peano-Baker terms of order
    ``k >= 2`` differ from those of ``expm(T X_c)`` by at most
    ``T^k ((|X_c| + Dbar)^k - |X_c|^k) / k!`` entrywise; the first-order term is exact.
    """
    Xc = 0.5 * (np.max(Xs, axis=0) + np.min(Xs, axis=0))
    Dbar = np.max([np.abs(X - Xc) for X in Xs], axis=0)
    Ac = np.abs(Xc)
    R = scipy.linalg.expm(T * (Ac + Dbar)) - scipy.linalg.expm(T * Ac) - T * Dbar
    return Xc, np.maximum(R, 0.0)


def _metzler_box(Xs, T: float):
    """Entrywise enclosure ``(lo, hi)`` of every LDI sample map, or None when not Metzler.

    ``lo = expm(T X_lo)``, ``hi = expm(T X_hi)`` (``X_lo``, ``X_hi`` the entrywise ends of the
    vertex matrices), each end moved outward by ``8 ulp |value| + 1e-300`` for the rounding of
    ``expm`` (see the module docstring for the comparison argument).
    """
    Xlo, Xhi = np.min(Xs, axis=0), np.max(Xs, axis=0)
    off = ~np.eye(Xlo.shape[0], dtype=bool)
    if np.any(Xlo[off] < 0.0):
        return None
    lo, hi = scipy.linalg.expm(T * Xlo), scipy.linalg.expm(T * Xhi)
    pad = 8.0 * np.finfo(float).eps * np.maximum(np.abs(lo), np.abs(hi)) + 1e-300
    lo, hi = np.where(lo == hi, lo, lo - pad), np.where(lo == hi, hi, hi + pad)
    if np.any(lo > hi):
        raise AssertionError("the Metzler comparison gave lo > hi")  # pragma: no cover
    return lo, hi


def _box_corners(lo, hi):
    """Every corner of the matrix box ``[lo, hi]`` (entries with ``lo < hi`` take either end)."""
    var = np.argwhere(hi > lo)
    out = []
    for bits in itertools.product((0, 1), repeat=len(var)):
        Psi = lo.copy()
        for (i, j), bit in zip(var, bits):
            if bit:
                Psi[i, j] = hi[i, j]
        out.append(Psi)
    return out, len(var)


def _sample_maps(L, Xs, second_order: bool = True):
    """``(maps, Rbar, model words, check)``: the matrices the LMI is posed on, the remainder,
    and the maps whose loops the NumPy re-check must contract (``check``; None: ``maps``).

    The interval ZOH model (exact enclosure, no remainder) when the vertex matrices are Metzler
    and the box has at most :data:`MAX_BOX_CORNERS` corners; else (``second_order``) the
    second-order model of :mod:`._sample_model` (the LMI on the corners' maps, the re-check on
    every pair of corners); else (or too many pairs) the first-order model.
    """
    T = L.T
    box = _metzler_box(Xs, T)
    if box is not None:
        maps, k = _box_corners(*box)
        if len(maps) <= MAX_BOX_CORNERS:
            return maps, None, (f"interval ZOH model (Metzler comparison, {k} varying entries of "
                                f"the sample map, {len(maps)} corners, no remainder)"), None
    why = ("the vertex matrices are not Metzler (an off-diagonal d sigma/d xi_i can be "
           "negative)" if box is None else f"the Metzler box has more than {MAX_BOX_CORNERS} "
           "corners")
    so = second_order_maps(Xs, T, L.loop.rho) if second_order else None
    if so is not None:
        return so.lmi, so.Rbar, (f"second-order model expm(T X_c) + T D(avg_1) + T^2/2 X_c "
                                 f"D(avg_2) + remainder, {len(so.pairs)} corner pairs: "
                                 f"{why}"), so.pairs
    Xc, Rbar = _remainder_bound(Xs, T)
    Ec = scipy.linalg.expm(T * Xc)
    return ([Ec + T * (X - Xc) for X in Xs], Rbar,
            f"first-order model expm(T X_c) + T (X - X_c) + remainder: {why}", None)


__all__ = ["MAX_BOX_CORNERS", "MAX_PAIRS", "SecondOrderMaps", "second_order_maps", "van_loan"]
