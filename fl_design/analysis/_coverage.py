"""eps* brackets ``[certified, refuted]`` per coverage: frozen, varying, rate-bounded, nonlinear.

What each coverage means for the surrogate loop ``X_(k+1) = M(b_k) X_k``:

* ``"frozen"``: every *constant* ``b`` of the interval. Certified by ``P(b)`` on pieces
  (closed-form modal or vertex LMIs); refuted by a frozen loop with an eigenvalue outside the
  unit circle (the bad end of the frozen scan).
* ``"varying"``: ``b_k`` anywhere in the interval, changing arbitrarily from sample to sample.
  Certified by one common quadratic ``P`` (the fast first try), then, between that and the
  refuted end, by a quartic sum-of-squares Lyapunov function (:mod:`._sos`, loops of at most
  :data:`SOS_MAX_STATES` states); refuted by a periodic or greedy switching sequence whose
  period map has spectral radius > 1 (:mod:`._refute`), or by a frozen counterexample.
* ``"rate-bounded"``: ``|b_(k+1) - b_k| <= db``. Certified by a ``P(b)`` affine in ``b`` with
  the rate bound (:mod:`._rate`), or by a varying certificate (which covers it); refuted by
  switching with ramps of slope ``db``, or a frozen counterexample.
* ``"nonlinear"``: the linear differential inclusion of :mod:`._ldi` (the plant in its region);
  no refutation is searched (a divergent surrogate is no counterexample for the plant).

``certified`` is the largest eps at which a certificate was found by the bisection (each eps
is its own certificate); ``refuted`` the smallest eps at which a counterexample was found. The
true boundary lies between them; ``gap = refuted / certified - 1`` says how tight that is
(down to the search resolution ``rtol``).

Examples
--------
>>> from fl_design.analysis._coverage import COVERAGES
>>> COVERAGES
('frozen', 'varying', 'rate-bounded', 'nonlinear')
"""

from __future__ import annotations

import numpy as np

from ._analytic import modal_lyapunov
from ._cert_results import EpsBracket, PointCertificate
from ._refute import Refutation, switching_refutation
from ._search import certified_eps_star, first_refuted
from ._sos import SOSSolution, sos_certificate
from ._sos_search import sos_eps_star
from ._surrogate import delta

COVERAGES = ("frozen", "varying", "rate-bounded", "nonlinear")
#: Largest loop (states) the quartic SOS certificate is tried on (8 states: a 36 x 36 Gram
#: matrix, about 2 s per eps with Clarabel; 11 states would be 66 x 66).
SOS_MAX_STATES = 8
#: Most quartic SOS programs one varying eps* search solves (the bisection stops there).
SOS_MAX_SOLVES = 8
COMMON_HOW = "one common quadratic P (delta-form LMI), re-checked in NumPy"
SOS_HOW = ("SOS degree 4: a quartic sum-of-squares V(x) common to both ends of b (Gram matrix and "
           "slack SDP, delta form, every T term kept), re-checked in NumPy; the joint spectral "
           "radius of the ends < 1 covers every b of the interval varying arbitrarily")


def coverage_of(b_rate, box) -> str:
    """The coverage the data supports: nonlinear (Jacobian bounds), frozen, rate or varying.

    Examples
    --------
    >>> coverage_of(None, None), coverage_of(0.0, None), coverage_of(0.01, None)
    ('varying', 'frozen', 'rate-bounded')
    """
    if box is not None:
        return "nonlinear"
    if b_rate is None:
        return "varying"
    return "frozen" if b_rate == 0.0 else "rate-bounded"


def sos_point(L, eps: float, gamma: float, *, slope: bool = False) -> SOSSolution:
    """Quartic SOS certificate of the varying coverage at one eps (:func:`._sos.sos_certificate`
    of the two ends of ``b``); not tried when a frozen loop is not Schur. ``slope``: also
    ``d eta / d eps`` (the ends' tangents by a central difference in eps, for
    :mod:`._sos_search`; the verdict does not depend on it).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.analysis._certify import _Loop
    >>> L = _Loop(fl.presets.paper_design(), (3.6, 6.8), None, 41, 8)
    >>> sos_point(L, 0.1, 3e-4).certified  # common P fails at 0.1
    True
    """
    if not L.frozen_ok(eps, gamma):
        return SOSSolution(False, "not solved", None, (), None, "a frozen loop is not Schur")
    D, K = L._deltas(eps, gamma, (L.b_lo, L.b_hi), structured=False)  # exact balancing
    tangents = None
    if slope:
        h, k = 1e-4, np.diag(K)  # D = K D_loop K^-1: the tangents alike
        ends = [[delta(M0 + b * M1, L.T) for b in (L.b_lo, L.b_hi)]
                for M0, M1 in (L.loop.parts(e, gamma) for e in (eps * (1 + h), eps * (1 - h)))]
        tangents = [(p - m) / (2 * h * eps) * k[:, None] / k[None, :] for p, m in zip(*ends)]
    return sos_certificate(D, L.T, tangents=tangents)


def varying_point(L, eps: float, gamma: float, failed):
    """The varying certificate at one eps when common P ``failed``: quartic SOS, else ``failed``.

    Tried only on loops of at most :data:`SOS_MAX_STATES` states (no Jacobian box).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.analysis._certify import _Loop
    >>> L = _Loop(fl.presets.paper_design(), (3.6, 6.8), None, 41, 8)
    >>> failed = L.point(0.1, 3e-4, common_only=True)
    >>> failed.certified, varying_point(L, 0.1, 3e-4, failed).kind
    (False, 'SOS degree 4')
    """
    if failed.certified or L.box is not None or L.loop.size > SOS_MAX_STATES:
        return failed
    sol = sos_point(L, eps, gamma)
    if not sol.certified:
        return failed
    return PointCertificate(
        float(eps), True, "SOS degree 4", 1, True, "CLARABEL", sol.status, sol.margin,
        f"{sol.note}; common P: {failed.reason}", ((L.b_lo, L.b_hi),), (), covers="varying")


def varying_certified(L, gamma: float, lo: float, c_common, top: float, rtol: float,
                      sos: bool = True):
    """``(eps, how)``: the varying certificate, common P's ``c_common`` or higher with SOS.

    The quartic SOS search runs (when ``sos`` and the loop has at most
    :data:`SOS_MAX_STATES` states) between ``c_common`` (``lo`` when None) and ``top`` (the
    refuted end): ``0.9 top`` first, steps of 0.9 down (0.5 without a common P), then Newton
    steps on the program's margin to ``rtol`` (:func:`._sos_search.sos_eps_star`), at most
    :data:`SOS_MAX_SOLVES` SDPs in all (about 1 s each at 7 states).
    """
    if not sos or L.loop.size > SOS_MAX_STATES or L.box is not None:
        return c_common, COMMON_HOW
    base = lo if c_common is None else c_common
    if top / base - 1.0 <= rtol:
        return c_common, COMMON_HOW
    def solve(e):
        sol = sos_point(L, e, gamma, slope=True)
        return sol.certified, sol.eta, sol.slope

    c_sos, _ = sos_eps_star(solve, base, top, rtol, hint=0.9,
                            step=0.5 if c_common is None else 0.9, budget=SOS_MAX_SOLVES)
    if c_sos is not None and (c_common is None or c_sos > c_common):
        return c_sos, SOS_HOW
    return c_common, COMMON_HOW


def refute(L, eps: float, gamma: float, db: float | None) -> Refutation:
    """Search an admissible switching of ``b`` that makes the surrogate grow (periodic, greedy).

    ``db`` None: jumps allowed (varying); a number: ramps of slope ``db`` (rate-bounded).
    """
    M0, M1 = L.loop.parts(eps, gamma)

    def M_at(b):
        return M0 + b * M1

    lo, hi = L.b_lo, L.b_hi
    mid = M_at(0.5 * (lo + hi))
    P = modal_lyapunov(delta(mid, L.T), L.T)
    w, V = np.linalg.eig(mid)
    x0 = np.real(V[:, int(np.argmax(np.abs(w)))])
    return switching_refutation(M_at, lo, hi, db, P=P, x0=x0)


def refuted_eps(L, gamma: float, db, start: float, frozen_bad: float | None, rtol: float,
                hi: float):
    """Smallest eps refuted by switching, scanned from ``start`` up (bisection to ``rtol``).

    Returns ``(eps, Refutation)``; the frozen counterexample ``frozen_bad`` bounds the scan
    (``(frozen_bad, None)`` when switching finds nothing below it, ``(None, None)`` when
    neither exists).
    """
    top = frozen_bad if frozen_bad is not None else hi
    if start >= top or L.b_lo == L.b_hi:  # one b: switching is no more than frozen
        return frozen_bad, None
    out = first_refuted(lambda e: refute(L, e, gamma, db), start, top, 10, rtol)
    return (frozen_bad, None) if out is None else out


def bracket(covers: str, certified, refuted, how_certified: str,
            refutation: Refutation | None, frozen_bad, db=None) -> EpsBracket:
    """An :class:`EpsBracket` with the refutation in words."""
    if refutation is not None:
        how = refutation.how
    elif refuted is not None and frozen_bad is not None and refuted == frozen_bad:
        how = "a constant b of the grid gives a loop with an eigenvalue outside the unit circle"
    else:
        how = "no counterexample found in the eps range"
    return EpsBracket(covers, None if certified is None else float(certified),
                      None if refuted is None else float(refuted), how_certified, how,
                      None if db is None else float(db),
                      () if refutation is None else refutation.runs)


def best_margin(L, gamma: float, lo: float, hi: float, n: int = 24, *, where: bool = False):
    """Smallest frozen margin over eps in ``[lo, hi]``: a log scan, then a bounded 1-D search.

    Negative: some eps gives a Schur loop for every b of the grid at this gamma. ``where``:
    ``(margin, eps)``, the eps where it was found.
    """
    from scipy.optimize import minimize_scalar

    grid = np.geomspace(lo, hi, n)
    m = np.asarray(L.frozen_margins(grid, gamma), dtype=float)  # stacked eigenvalue problems
    i = int(np.argmin(m))
    if m[i] < 0.0:
        return (float(m[i]), float(grid[i])) if where else float(m[i])
    a, b = np.log(grid[max(i - 1, 0)]), np.log(grid[min(i + 1, n - 1)])
    res = minimize_scalar(lambda x: L.frozen_margin(float(np.exp(x)), gamma), bounds=(a, b),
                          method="bounded", options={"xatol": 1e-6})
    out = (float(m[i]), float(grid[i])) if m[i] <= res.fun else (float(res.fun),
                                                                 float(np.exp(res.x)))
    return out if where else out[0]


def gamma_fix(L, gamma: float, lo: float, hi: float, n: int = 40) -> str:
    """What would make some eps of ``[lo, hi]`` work, when none does at ``|gamma|``.

    Scans ``n`` log-spaced ``|gamma|`` in ``[1e-4 T, 4] / |b|_max`` with :func:`best_margin`
    and names the nearest stable run (``"|gamma| >= ..."`` or ``"|gamma| <= ..."``), or says
    that no gain of the scan works (then the gains, ``k_I`` or ``T`` must change).
    """
    grid = np.geomspace(1e-4 * L.T / L.b_hi, 4.0 / L.b_hi, n)
    ok = np.array([best_margin(L, float(g), lo, hi) < 0.0 for g in grid])
    if not ok.any():
        return (f"no |gamma| in [{grid[0]:.3g}, {grid[-1]:.3g}] gives a stable surrogate at any eps"
                f" of [{lo:g}, {hi:g}] for every |b| in [{L.b_lo:.4g}, {L.b_hi:.4g}]: narrow the "
                f"b interval (b_max/b_min = {L.b_hi / L.b_lo:.3g}: a smaller region) or change the"
                " gains K, k_I or T; gamma alone cannot fix it")
    good = grid[ok]
    above, below = good[good > gamma], good[good < gamma]
    if above.size and (not below.size or above[0] / gamma < gamma / below[-1]):
        return (f"raise |gamma| to at least ~{above[0]:.3g} (|gamma| >= {above[0]:.3g} gives a "
                "stable surrogate for some eps; see certify_gamma for the exact bound)")
    return (f"lower |gamma| to at most ~{below[-1]:.3g} (|gamma| <= {below[-1]:.3g} gives a "
            "stable surrogate for some eps)")


def coverage_brackets(L, gamma: float, lo: float, frozen, rtol: float, b_rate,
                      rate_point=None, sos: bool = True) -> tuple[dict, float | None]:
    """The brackets of every coverage the data allows, keyed by coverage name, and the
    common-P eps* (the varying bracket may be higher: quartic SOS, ``sos``).

    ``frozen`` is ``(good, bad)`` of the frozen scan (None when ``lo`` already fails);
    ``rate_point(eps) -> bool`` certifies the rate-bounded case at one eps (optional).
    """
    good, bad = frozen if frozen is not None else (None, None)
    out = {}
    if good is None:
        b = bracket("frozen", None, lo, "no eps of the range", None, lo)
        return {"frozen": b, "varying": bracket("varying", None, lo, "-", None, lo)}, None
    c_frozen = certified_eps_star(lambda e: L.search_ok(e, gamma), lo, good, rtol)
    out["frozen"] = bracket("frozen", c_frozen, bad, "P(b) on pieces of the interval (modal "
                            "closed form or vertex LMIs), re-checked in NumPy", None, bad)
    c_common = certified_eps_star(lambda e: L.point(e, gamma, common_only=True).certified,
                                  lo, good, rtol)
    r_var, ref = refuted_eps(L, gamma, None, c_common or lo, bad, rtol, good)
    c_var, how = varying_certified(L, gamma, lo, c_common, good if r_var is None else r_var,
                                   rtol, sos and b_rate != 0.0)  # frozen b: not the headline
    out["varying"] = bracket("varying", c_var, r_var, how, ref, bad)
    if b_rate is not None and b_rate > 0.0:
        c_rate, how = c_var, "the varying certificate (covers every rate)"
        if rate_point is not None:
            # jumps are not admissible here: the varying refutation does not bound this search
            c2 = certified_eps_star(rate_point, lo, good, rtol,
                                    hint=1.0 if c_var is None else min(1.0, c_var / good))
            if c2 is not None and (c_rate is None or c2 > c_rate):
                c_rate, how = c2, ("P(b) piecewise affine in b with the rate bound and a slack "
                                   "per piece (delta-form LMI), re-checked in NumPy")
        r_rate, ref = refuted_eps(L, gamma, b_rate, c_rate or lo, bad, rtol, good)
        out["rate-bounded"] = bracket("rate-bounded", c_rate, r_rate, how, ref, bad, b_rate)
    return out, c_common


__all__ = ["COMMON_HOW", "COVERAGES", "SOS_HOW", "SOS_MAX_SOLVES", "SOS_MAX_STATES", "best_margin",
           "bracket", "coverage_brackets", "coverage_of", "gamma_fix", "refute", "refuted_eps",
           "sos_point", "varying_certified", "varying_point"]
