"""eps* brackets of a class with a slope box: certified by the LDI, refuted by the class's members.

A class with a slope box ``a_slopes`` (and ``b`` in its range) holds every plant
``sigma = a(t)^T xi + b(t) u`` with ``a(t)``, ``b(t)`` inside the box along the trajectory; the
certificate is the common-``P`` LDI of :mod:`._ldi` (coverage ``"nonlinear"``). Its bracket:

* **certified**: the largest eps of a bisection at which the LDI certificate re-checks
  (below the frozen scan's good end);
* **refuted**: the smallest eps at which a *member* of the class is found unstable:
  a **frozen corner** (constant ``a`` at a corner of the box, constant ``b`` of the grid: an LTI
  member, the bad end of the frozen scan), or a **switching** between two corner plants
  (each sample one corner's exact ZOH; :func:`._refute.switching_refutation` on pairs of the
  ``2^k`` corners, ``k`` the varying entries of ``(a, b)``, fewest differing entries first);
  pairs whose ``b`` differs only when the class lets ``b`` jump (no rate bound, or one at least
  the range's width): a class with ``b`` constant per plant (a parameter box) or rate-bounded
  switches the slopes only.

The **frozen members** bracket (every member with constant ``a`` and ``b``: each
linearization of the plant in its region) is refuted by the frozen corners; its certified end
is the LDI's (a parameter-dependent ``P`` over the enclosure's corners took 1-2 s per eps on
the TRMS and rarely certified more: not searched). It is reported beside the headline, never
as it: the plant's slopes follow its state in time. The frozen scan covers the box's corners
(and the ``b`` grid), not its interior: a member inside the box less stable than every corner
would put the true frozen boundary below the reported one (not searched; on the benchmark's
class the corners are the worst members, ``tests/analysis/test_slope_box.py``). The refuted end
is a real member either way.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.analysis._certify import _Loop
>>> L = _Loop(fl.presets.pendulum_design(), (1.0, 1.0), [(-9.81, -9.0), (-0.5, -0.5)], 41, 8)
>>> len(corner_plants(L))
2
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from ._coverage import bracket
from ._refute import Refutation, switching_refutation
from ._search import certified_eps_star, first_refuted
from ._surrogate import chain_zoh, delta, schur_margins

#: Most corner pairs the switching refutation tries (each a periodic + greedy search).
MAX_PAIRS = 16
LDI_HOW = ("one common quadratic P over every sample map of the slope box x b range (the LDI, "
           "interval ZOH or first-order model with remainder), re-checked in NumPy")


def corner_plants(L) -> list:
    """``[(a_row, b)]``: the distinct corners of the class's ``(a, b)`` box (LTI members)."""
    corners = np.unique(L._corners(), axis=0)
    return [(a, b) for a in corners for b in sorted({L.b_lo, L.b_hi})]


def _corner_matrix(L, eps, gamma, a_row, b):
    M0, M1 = L.loop.parts(eps, gamma, a_row)
    return M0 + b * M1


def switching_refute(L, eps: float, gamma: float) -> Refutation:
    """The worst switching between two corner plants at ``eps`` (first refuting pair)."""
    corners = corner_plants(L)
    pairs = admissible_pairs(L)
    best = Refutation(False, math.nan, 0, "no admissible pair of corners")
    mats = [_corner_matrix(L, eps, gamma, a, b) for a, b in corners] if pairs else []
    for i, j in pairs:
        Mi, Mj = mats[i], mats[j]
        r = switching_refutation(lambda t, Mi=Mi, Mj=Mj: Mi if t < 0.5 else Mj, 0.0, 1.0, None)
        if r.refuted or not math.isfinite(best.radius) or r.radius > best.radius:
            words = (f"switching between the corner plants {_words(*corners[i])} and "
                     f"{_words(*corners[j])}: {r.how.replace('b = 0', 'the first').replace('b = 1', 'the second')}")
            best = Refutation(r.refuted, r.radius, r.period, words, r.runs)
        if best.refuted:
            return best
    return best


def admissible_pairs(L) -> list:
    """Index pairs of :func:`corner_plants` a member may switch between, fewest differing
    entries first, at most :data:`MAX_PAIRS` (see :func:`b_may_jump`)."""
    corners = corner_plants(L)
    keys = [np.r_[a, b] for a, b in corners]
    jumps = b_may_jump(L)
    return sorted((ij for ij in itertools.combinations(range(len(corners)), 2)
                   if jumps or corners[ij[0]][1] == corners[ij[1]][1]),
                  key=lambda ij: int(np.sum(keys[ij[0]] != keys[ij[1]])))[:MAX_PAIRS]


def b_may_jump(L) -> bool:
    """Whether a member's ``b`` may jump between the ends of its range from one sample to the
    next: no rate bound (``L.b_rate`` None) or one at least the range's width. Otherwise (``b``
    constant per plant, or rate-bounded) only corners with the same ``b`` are switched."""
    rate = getattr(L, "b_rate", None)
    return rate is None or rate >= L.b_hi - L.b_lo


def _words(a_row, b) -> str:
    if a_row is None:
        return f"(a = 0, b = {b:.6g})"
    return f"(d sigma/d xi = ({', '.join(f'{v:.6g}' for v in a_row)}), b = {b:.6g})"


def refuted_by_switching(L, gamma: float, start: float, frozen_bad, rtol: float, hi: float):
    """``(eps, Refutation)``: smallest eps refuted by corner switching, from ``start`` up to the
    frozen counterexample (or ``hi``); ``(frozen_bad, None)`` when switching finds nothing."""
    top = frozen_bad if frozen_bad is not None else hi
    if start >= top or not admissible_pairs(L):
        return frozen_bad, None
    out = first_refuted(lambda e: switching_refute(L, e, gamma), start, top, 6, rtol,
                        below=frozen_bad)
    return (frozen_bad, None) if out is None else out


def class_brackets(L, gamma: float, lo: float, fb, rtol: float) -> dict:
    """``{"nonlinear": EpsBracket, "frozen": EpsBracket}`` of a class with a slope box.

    ``fb`` is the frozen scan's ``(good, bad)`` over the corners and the ``b`` grid (None when
    ``lo`` already fails). The LDI is searched only when no corner switching refutes ``lo``
    (then no certificate exists there; at each eps a member found unstable skips the LMI);
    the frozen bracket's certified end is the LDI's (it covers every frozen member too).
    """
    if fb is None:
        none = bracket("nonlinear", None, lo, "no eps of the range", None, lo)
        return {"nonlinear": none, "frozen": bracket("frozen", None, lo, "-", None, lo)}
    good, bad = fb
    first = switching_refute(L, lo, gamma) if admissible_pairs(L) else None
    c_ldi = None
    if first is not None and first.refuted:
        r, ref = lo, first
    else:
        c_ldi = certified_eps_star(lambda e: L.search_ok(e, gamma), lo, good, rtol,
                                   step=0.3)  # one SDP per eps: few steps down
        r, ref = refuted_by_switching(L, gamma, c_ldi or lo, bad, rtol, good)
    return {"nonlinear": bracket("nonlinear", c_ldi, r, LDI_HOW, ref, bad),
            "frozen": bracket("frozen", c_ldi, bad, "the LDI's common P (covers every frozen "
                              "member)", None, bad)}


def member_refutation_point(L, eps: float, gamma: float):
    """A not-certified :class:`PointCertificate` when a member of the class is found unstable at
    ``eps`` (a frozen corner, or a switching between two corners), else None (then the LDI is
    worth solving).

    ``L.refute_points = False`` (the fast curve's searches, where a switching search cost as
    much as the LDI's SDP at each eps and rarely refuted): the frozen corners only."""
    from ._cert_results import PointCertificate

    m = frozen_corner_margin(L, eps, gamma)
    if not m < 0.0:
        return PointCertificate(float(eps), False, None, 0, False, None, "not solved", None,
                                f"a frozen corner plant of the class is not Schur (margin "
                                f"{m:.3g} >= 0): no certificate exists, no LMI solved")
    if not getattr(L, "refute_points", True) or not admissible_pairs(L):
        return None  # (a search that wants certificates only: the LDI answers)
    r = switching_refute(L, eps, gamma)
    if not r.refuted:
        return None
    return PointCertificate(float(eps), False, None, 0, False, None, "not solved", None,
                            f"a member of the class grows ({r.how} > 1, a "
                            f"{r.period}-sample period): no certificate exists for this class, "
                            "no LMI solved")


def box_frozen_margins(L, eps_values, gamma: float) -> np.ndarray:
    """``L.frozen_margin`` at many eps for a slope box: the chain's stacked parts with
    each corner's plant block (``Phi_a``, ``Gamma_a``, exact ZOH) swapped in."""
    rho = L.loop.rho
    M0, M1 = L.loop.parts_many(eps_values, gamma)
    _, G0 = chain_zoh(rho, L.T)
    worst = np.full(len(eps_values), -np.inf)
    for a_row in L._corners():
        Phi, Ga = chain_zoh(rho, L.T, a_row)
        A0, A1 = M0.copy(), M1.copy()
        A0[:, :rho, :rho] = Phi
        A1[:, :rho] *= (Ga / G0)[None, :, None]
        M = A0[:, None] + L.b_grid[None, :, None, None] * A1[:, None]
        m = schur_margins(delta(M, L.T), L.T).max(axis=-1)
        worst = np.maximum(worst, np.where(np.isfinite(m), m, np.inf))
    return worst


def member_radii(L, eps_values, gamma: float):
    """``(members, radii)``: the frozen members (a corner of the slope box, or ``a = 0``, and
    ``b`` of the grid) as ``(a_row, b)``, and the spectral radius of each one's sampled loop at
    each eps (shape ``(members, eps)``; the exact ZOH of the member's plant)."""
    rho = L.loop.rho
    eps_values = np.asarray(eps_values, dtype=float)
    M0, M1 = L.loop.parts_many(eps_values, gamma)
    _, G0 = chain_zoh(rho, L.T)
    members, radii = [], []
    for a_row in L._corners():
        A0, A1 = M0, M1
        if a_row is not None:
            Phi, Ga = chain_zoh(rho, L.T, a_row)
            A0, A1 = M0.copy(), M1.copy()
            A0[:, :rho, :rho] = Phi
            A1[:, :rho] *= (Ga / G0)[None, :, None]
        M = A0[None] + L.b_grid[:, None, None, None] * A1[None]
        rad = np.max(np.abs(np.linalg.eigvals(M)), axis=-1)
        for i, b in enumerate(L.b_grid):
            members.append((None if a_row is None else np.asarray(a_row, dtype=float),
                            L.sign * float(b)))
            radii.append(rad[i])
    return members, np.array(radii)


def no_stable_eps(L, gamma: float, lo: float, hi: float, n: int = 48) -> str | None:
    """Why no eps of ``[lo, hi]`` is frozen-stable at ``gamma``, in words, or None.

    On ``n`` log-spaced eps of the range, every frozen member's sampled loop
    (:func:`member_radii`) is evaluated: None when at some eps all are Schur (then the
    frozen-stable eps exist, perhaps as a band away from ``lo``); else the member unstable at
    every scanned eps with the smallest worst radius (the gain cannot be certified for the
    class: that plant of the class is unstable whatever eps), or, when no single member is,
    the members that take turns.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.analysis._certify import _Loop
    >>> d = fl.Design(estimator=fl.EHGO(2, 1e-2, 1e-3), controller=fl.DynamicController((1, 2), 0.1))
    >>> L = _Loop(d, (1.0, 5.0), [(-0.2, 0.2), (-0.1, 0.1)], 41, 8)
    >>> no_stable_eps(L, 0.2, 1e-3, 1.0)[:43]
    'no eps of [0.001, 1] stabilizes the member '
    >>> no_stable_eps(L, 0.004, 1e-3, 1.0) is None
    True
    """
    eps = np.geomspace(lo, hi, int(n))
    members, rad = member_radii(L, eps, gamma)
    bad = ~(rad < 1.0)
    if not np.all(np.any(bad, axis=0)):
        return None
    always = np.flatnonzero(np.all(bad, axis=1))
    if always.size:
        k = int(always[np.argmax(np.min(rad[always], axis=1))])
        a, b = members[k]
        who = ("the chain member" if a is None else
               f"the member d sigma/d xi = ({', '.join(f'{v:.6g}' for v in a)})") + f", b = {b:.6g}"
        return (f"no eps of [{lo:g}, {hi:g}] stabilizes {who} at gamma = {gamma:.6g}: its "
                f"sampled loop has spectral radius >= {float(np.min(rad[k])):.9f} > 1 at each "
                f"of {eps.size} log-spaced eps (worst {float(np.max(rad[k])):.6g}); this gain "
                "cannot be certified for the class")
    turns = sorted({int(np.argmax(rad[:, j])) for j in range(eps.size)})
    names = "; ".join(_words(*members[k]) for k in turns[:4])
    return (f"no eps of [{lo:g}, {hi:g}] is frozen-stable at gamma = {gamma:.6g}: at each of "
            f"{eps.size} log-spaced eps some member is unstable (in turn: {names}); this gain "
            "cannot be certified for the class")


def frozen_nan_reason(L, gamma: float, lo: float, hi: float) -> str:
    """Why a curve's frozen eps* is NaN at ``gamma`` (its loop unstable at ``eps = lo``):
    :func:`no_stable_eps`, or the band of stable eps away from ``lo`` that the search (which
    starts at ``lo``) does not report."""
    why = no_stable_eps(L, gamma, lo, hi)
    if why is not None:
        return why
    return (f"gamma = {gamma:.6g}: a frozen member is unstable at eps = {lo:g} but every "
            f"member is Schur at some larger eps (a band away from eps = {lo:g}): the curve "
            "starts at the range's lower end and reports NaN there (certify_eps lists the band)")


def uncertified_words(gamma: float, tried: float, frozen: float, lo: float) -> str:
    """Why a curve's certified eps* is NaN at ``gamma`` though its frozen eps* is not.

    Examples
    --------
    >>> uncertified_words(0.1, 1e-3, 0.0017, 1e-3)[:46]
    'gamma = 0.1: no certificate found at eps = 0.0'
    """
    where = f"eps = {tried:.6g} " + ("(the range's lower end)" if tried <= lo else
                                      "(half the frozen eps*; not searched below it)")
    return (f"gamma = {gamma:.6g}: no certificate found at {where}; the eps up to the frozen "
            f"eps* {frozen:.6g} (above it a frozen member is unstable) are undecided, not "
            "refuted (NaN: not certified)")


def frozen_corner_margin(L, eps: float, gamma: float) -> float:
    """Largest Schur margin over the corner plants (``< 0``: every corner is Schur)."""
    D = [delta(_corner_matrix(L, eps, gamma, a, b), L.T) for a, b in corner_plants(L)]
    return float(np.max(schur_margins(np.stack(D), L.T)))


__all__ = ["LDI_HOW", "admissible_pairs", "b_may_jump", "box_frozen_margins", "class_brackets",
           "corner_plants", "frozen_corner_margin", "frozen_nan_reason", "member_radii",
           "member_refutation_point", "no_stable_eps", "refuted_by_switching", "switching_refute",
           "uncertified_words"]
