"""Admissible ``gamma`` interval of the surrogate loop and the gamma below which no eps works.

Examples
--------
>>> import fl_design as fl
>>> g = fl.certify_gamma(fl.presets.paper_design(), (3.6, 6.8))
>>> g.certified, g.point.covers
(True, 'varying')
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .. import _validate as V
from .._numerics import bisect_log
from ..errors import CertificationError, ParameterError
from ._cert_results import GammaCertificate, class_fields
from ._certify import DEFAULT_EPS_RANGE, _eps_range, _Loop, _serial
from ._class_resolve import resolve_class
from ._coverage import best_margin, coverage_of
from ._search import gamma_interval

if TYPE_CHECKING:  # annotations only (no import at run time)
    from ..design import Design


@_serial
def certify_gamma(design: Design, b_bounds, *, a_jacobian_bounds=None, b_rate=None,
                  gamma_range=None, eps_grid=None, n_scan: int = 80, n_b: int = 41, rtol: float = 1e-3,
                  max_pieces: int = 8, raise_on_failure: bool = False) -> GammaCertificate:
    """Admissible ``gamma`` interval of the surrogate loop at the design's eps, and a certificate.

    ``gamma_min``, ``gamma_max`` bound the run of a log-spaced gamma scan (refined by bisection
    to ``rtol``) that contains the design's gamma, on which every frozen-b loop of the ``n_b``
    grid is Schur (the surrogate of :mod:`fl_design.analysis._certify`, at the design's eps and
    T). ``gamma_lower_bound``: below it no eps of ``[1e-3, 1]`` gives a Schur loop for every
    ``b`` of the grid (``b gamma / T`` slower than the closed loop); the smallest ``gamma_min``
    over ``eps_grid``, refined by bisection in gamma (to 1e-4 relative) of "some eps works",
    each tested by a log eps scan and a bounded 1-D minimization of the frozen margin.
    ``certified`` needs the gamma inside the interval *and* the LMI certificate at the
    design's ``(eps, gamma)``. Gains are magnitudes: for ``b < 0``, ``gamma`` means
    ``-|gamma|`` and the bounds are on ``|gamma|``.

    Parameters
    ----------
    design : Design
        An EHGO design.
    b_bounds : (float, float) or PlantBounds
        ``(b_min, b_max)`` of one strict sign, or :func:`fl_design.analysis.plant_bounds` over a
        parameter box (see :func:`certify_eps`).
    a_jacobian_bounds : sequence of (float, float) or "plant", optional
        Bounds of ``d sigma/d x_i`` (see :func:`certify_eps`).
    b_rate : float or "plant", optional
        What is known of ``b`` in time (see :func:`certify_eps`): the coverage of ``point``.
    gamma_range : (float, float), optional
        Scan interval (default ``(1e-4 T, 4) / |b|_max``).
    eps_grid : sequence of float, optional
        Eps values of ``gamma_lower_bound`` (default 6 log-spaced in ``[1e-3, 1]`` and the
        design's eps).
    n_scan : int, optional
        Scan points (default 80).
    n_b : int, optional
        Points of the b grid (default 41).
    rtol : float, optional
        Relative resolution of the interval ends (default 1e-3).
    max_pieces : int, optional
        As in :func:`certify_eps`.
    raise_on_failure : bool, optional
        Raise :class:`~fl_design.errors.CertificationError` when not certified.

    Returns
    -------
    GammaCertificate

    Examples
    --------
    >>> import fl_design as fl
    >>> g = fl.certify_gamma(fl.presets.paper_design(gamma=1e-4), (3.6, 6.8))
    >>> g.certified, g.gamma_lower_bound > 1e-4
    (False, True)
    """
    r = resolve_class(b_bounds, b_rate, a_jacobian_bounds, design)
    b_bounds, b_rate, a_jacobian_bounds, params = r.b_bounds, r.b_rate, r.a_jacobian_bounds, r.params
    L = _Loop(design, b_bounds, a_jacobian_bounds, n_b, max_pieces)
    if b_rate is not None:
        b_rate = V.nonnegative("b_rate", b_rate)
    n_scan = V.integer("n_scan", n_scan, minimum=3)
    rtol = V.positive("rtol", rtol)
    eps, gamma = design.estimator.eps, abs(design.controller.gamma)  # b gamma > 0: magnitudes
    g_lo, g_hi = ((1e-4 * design.T / L.b_hi, 4.0 / L.b_hi) if gamma_range is None
                  else _eps_range(gamma_range))
    grid_eps = (np.geomspace(*DEFAULT_EPS_RANGE, 6) if eps_grid is None
                else V.real_vector("eps_grid", eps_grid))
    grid_eps = np.unique(np.concatenate([grid_eps, [eps]]))
    if np.any(grid_eps <= 0):
        raise ParameterError(f"eps_grid must be > 0, got {grid_eps.tolist()}")
    def scan(e):  # the whole gamma scan at one eps: one stacked eigenvalue call
        return lambda gs: L.frozen_margins(np.full(len(gs), float(e)), gs) < 0.0

    g_min, g_max = gamma_interval(lambda g: L.frozen_ok(eps, g), gamma, g_lo, g_hi, n_scan,
                                  rtol, scan(eps))
    mins = [g_min if e == eps else  # (the design's eps: its scan above)
            gamma_interval(lambda g, e=e: L.frozen_ok(e, g), gamma, g_lo, g_hi, n_scan, rtol,
                           scan(e), lower_only=True)[0] for e in grid_eps]
    mins = [m for m in mins if m is not None]
    lower = min(mins) if mins else None
    if lower is not None:
        lower = refine_lower_bound(L, lower, g_lo, *DEFAULT_EPS_RANGE)
    point = L.covered_point(eps, gamma, coverage_of(b_rate, L.box), b_rate)
    inside = g_min is not None and g_min < gamma < g_max
    certified = bool(inside and point.certified)
    reason = _gamma_reason(gamma, eps, g_min, g_max, lower, point, inside)
    if raise_on_failure and not certified:
        raise CertificationError(reason)
    return GammaCertificate(
        gamma=float(gamma), eps=float(eps), T=design.T, b_bounds=L.signed_bounds,
        paper_bound=1.0 / L.b_hi, convergence_bound=2.0 / L.b_hi, gamma_min=g_min,
        gamma_max=g_max, gamma_lower_bound=lower, eps_grid=tuple(grid_eps.tolist()),
        certified=certified, point=point, reason=reason, params=params,
        **class_fields(r.cls))


#: Relative width of the bracket of the refined gamma lower bound.
LOWER_RTOL = 1e-4


def refine_lower_bound(L, good: float, g_floor: float, lo: float, hi: float) -> float:
    """The gamma below which no eps in ``[lo, hi]`` works, bracketed to :data:`LOWER_RTOL`.

    ``good`` is a gamma at which some eps works; the bracket's lower (failing) end is found by
    steps down by squared factors (``1 + 4 LOWER_RTOL``, its square, ...: the scans' ends
    already lie within their ``rtol`` of the answer), then log-bisection. Returns the good end
    (some eps works there, none at ``good / (1 + LOWER_RTOL)`` as far as :func:`best_margin`
    finds). The eps that worked last is tried first at the next gamma: a witness (some eps
    works) without the search.
    """
    witness = [None]

    def works(g):
        e = witness[0]
        if e is not None and L.frozen_margin(e, g) < 0.0:
            return True
        m, e = best_margin(L, g, lo, hi, where=True)
        if m < 0.0:
            witness[0] = e
        return m < 0.0

    if not works(good):
        return good
    factor = 1.0 + 4.0 * LOWER_RTOL
    bad = good / factor
    while works(bad):
        if bad <= g_floor:
            return bad
        factor *= factor
        good, bad = bad, bad / factor
    out = bisect_log(lambda x: works(1.0 / x), 1.0 / good, 1.0 / bad, rtol=LOWER_RTOL)
    return float(1.0 / out.lo)


def _gamma_reason(gamma, eps, g_min, g_max, lower, point, inside) -> str:
    if lower is not None and gamma < lower:
        return (f"gamma = {gamma:g} is below the lower bound gamma_min = {lower:.6g}: the loop "
                "is unstable for every eps of the grid (b gamma / T slower than the closed loop)")
    if g_min is None:
        return f"no gamma of the scan gives a stable loop at eps = {eps:g}"
    if not inside:
        return (f"gamma = {gamma:g} lies outside the admissible interval "
                f"({g_min:.6g}, {g_max:.6g}) at eps = {eps:g}")
    if not point.certified:
        return f"gamma inside ({g_min:.6g}, {g_max:.6g}) but no LMI certificate: {point.reason}"
    return (f"gamma = {gamma:g} inside ({g_min:.6g}, {g_max:.6g}), LMI certificate "
            f"({point.kind}) at eps = {eps:g}")



__all__ = ["certify_gamma"]
