"""Peak-gain bounds of the Q31 step's values that are affine in the observer's state and ``y``.

Interval arithmetic adds the ranges of a sum's terms as if they were independent; a high-gain
observer's estimates are large terms that cancel, so their sums' intervals (and the fraction
bits chosen from them) are far wider than the values ever get. A value ``c xi + d y`` of an
observer ``xi' = A xi + B y`` driven from rest by any ``y`` within ``mid +- half`` lies within
``c rest(mid) + d mid +- (|d| + sum_j |c A^j B|) half``, and that bound is reached (the
record ``y_k = mid + half sign(...)``): the sup over every admissible record, as the state
boxes (:func:`._q31.state_box`) are. :func:`._q31._analyse` intersects the two bounds.

Examples
--------
>>> import numpy as np
>>> from fl_design.codegen._q31_peak import PeakGain
>>> peak = PeakGain(np.array([[0.5]]), np.array([0.5]), np.array([0.0]), 0.0, 1.0)
>>> peak.bound(({0: 1.0, "y": -1.0}, 0.0))  # xi - y: |d| + sum 0.5^(j+1) = 2
(-2.0, 2.0)
"""

from __future__ import annotations

import casadi as ca
import numpy as np


class PeakGain:
    """Bounds of the values affine in the observer's state and ``y`` by their peak gain.

    Parameters
    ----------
    A, B : numpy.ndarray
        The observer's update.
    rest : numpy.ndarray
        Its rest state at ``y = mid``.
    mid, half : float
        The range of ``y``: ``mid +- half``.


    A value ``c xi + d y + (terms in r, u, z)`` of the step, the observer ``xi' = A xi + B y``
    driven from rest by any ``y`` within ``mid +- half``, lies within ``c rest(mid) + d mid
    +- (|d| + sum_j |c A^j B|) half`` (plus the other terms' intervals): the sup over every
    such record, exact, where interval arithmetic adds the terms' ranges as if they were
    independent (a sum of large estimates that cancel, as a high-gain observer's are, is
    bounded by their sum of magnitudes). The two bounds are intersected."""

    def __init__(self, A, B, rest, mid, half):
        self.rest, self.mid, self.half, self.m = rest, mid, half, len(B)
        cols, v = [], np.asarray(B, dtype=float)
        total = 0.0
        for _ in range(200_000):
            cols.append(v)
            total += float(np.max(np.abs(v)))
            v = A @ v
            if float(np.max(np.abs(v))) <= 1e-16 * total:
                break
        self.H = np.array(cols).T  # (m, N): A^j B

    def bound(self, form):
        """``(lo, hi)`` of the affine ``form`` (``{input index: coef}``, const) over the
        observer's part (the caller adds the other inputs' intervals).

        Parameters
        ----------
        form : tuple
            ``({index or "y": coefficient}, constant)``.

        Returns
        -------
        tuple of float
        """
        coef, const = form
        c = np.zeros(self.m)
        d = 0.0
        for i, v in coef.items():
            if i == "y":
                d = v
            else:
                c[i] = v
        center = const + float(c @ self.rest) + d * self.mid
        rad = (abs(d) + float(np.sum(np.abs(c @ self.H)))) * self.half
        return center - rad, center + rad


def affine_step(op, a, forms, const):
    """The affine form of an instruction from its operands' (None when it is not affine).

    Parameters
    ----------
    op : int
        CasADi operation.
    a : list of int
        Its operands (instruction indices).
    forms : dict
        Instruction -> affine form ``({input: coefficient}, constant)``.
    const : dict
        Instruction -> value of the constants.

    Returns
    -------
    tuple or None
    """
    fa = [forms.get(j) for j in a]
    if any(v is None for v in fa):
        return None

    def lin(f1, s1, f2, s2):
        d = {i: s1 * v for i, v in f1[0].items()}
        for i, v in (f2[0].items() if f2 else ()):
            d[i] = d.get(i, 0.0) + s2 * v
        return d, s1 * f1[1] + (s2 * f2[1] if f2 else 0.0)

    if op == ca.OP_ADD:
        return lin(fa[0], 1.0, fa[1], 1.0)
    if op == ca.OP_SUB:
        return lin(fa[0], 1.0, fa[1], -1.0)
    if op == ca.OP_NEG:
        return lin(fa[0], -1.0, None, 0.0)
    if op == ca.OP_TWICE:
        return lin(fa[0], 2.0, None, 0.0)
    if op == ca.OP_ASSIGN:
        return fa[0]
    if op == ca.OP_MUL:
        for x, y in ((a[0], a[1]), (a[1], a[0])):
            if x in const:
                return lin(forms[y], const[x], None, 0.0)
    return None


def split_form(form, m):
    """The observer's part of an affine form (xi, y, const) and the rest (r, u, z).

    Parameters
    ----------
    form : tuple
        ``({input: coefficient}, constant)``; inputs ``0 .. m-1`` are the observer's state,
        ``"y"``, ``"r"`` and ``m, m+1`` (``u``, ``z``) the others.
    m : int
        The observer's state size.

    Returns
    -------
    tuple
        ``((own, constant), other)``.
    """
    mine = lambda i: i == "y" or (i != "r" and i < m)
    own = {i: v for i, v in form[0].items() if mine(i)}
    other = {i: v for i, v in form[0].items() if not mine(i)}
    return (own, form[1]), other


__all__ = ["PeakGain", "affine_step", "split_form"]
