"""Certified eps* and admissible gamma of the sampled linear surrogate loop.

**What a certificate covers.** The loop is the *linear surrogate* of :mod:`._surrogate`: the
plant is the chain of ``rho`` integrators with ``sigma = a^T x + b u`` (``a = 0`` unless
``a_jacobian_bounds`` are given) held over each sample (exact ZOH), closed by the design's own
step (EHGO, clamps and saturation inactive, dynamic controller, integrator) at the design's
``T``. A certificate at one ``eps`` is a Lyapunov matrix, found in closed form
(:mod:`._analytic`) or by an LMI (:mod:`._lmi`, delta form, balanced), re-checked in NumPy:

* kind ``"common"`` (covers ``"varying"`` b): one quadratic Lyapunov function for both ends of
  the ``b`` interval: the loop is exponentially stable for every sequence ``b_k`` in the
  interval (``b`` may vary from sample to sample);
* kind ``"parameter-dependent"`` (covers ``"frozen"`` b): ``P(b)`` on each of ``pieces``
  sub-intervals covering the interval, either one closed-form modal ``P`` per piece
  (:mod:`._analytic`) or vertex matrices ``P_v`` with a common slack ``G`` (LMI): every
  *constant* ``b`` of the interval gives a Schur loop (robust stability, not time variation
  across pieces).

**How a point is certified** (:class:`._cert_loop._Loop`, cheapest first): the frozen loops on the ``b`` grid must be
Schur (else no Lyapunov function exists and nothing is solved); then closed-form modal
Lyapunov candidates on adaptively halved pieces (down to ``max_pieces * MODAL_SPLIT`` pieces),
each accepted only when the NumPy re-check of :func:`._lmi.recheck` passes at both ends of its
piece (the vertex matrix is affine in ``Delta(b)``, so the ends cover the piece); then the
LMIs (parameter-dependent on the whole interval, common ``P``, parameter-dependent on pieces).
A search (eps*) that already found a closed-form certificate at this gamma skips the LMIs at
larger eps: a point left uncertified is never unsound. The certificate's ``b_pieces`` and
``lyapunov`` (``P`` per piece, the loop's coordinates) let anyone re-check it.

**What is reported** (:mod:`._coverage`): per coverage (``frozen``: constant ``b``;
``varying``: ``b`` arbitrary in time; ``rate-bounded``; ``nonlinear``) a bracket
``[certified, refuted]`` of eps*: the largest eps of a bisection (relative resolution ``rtol``)
at which a certificate of that coverage was found, and the smallest eps at which a
counterexample was found (a constant ``b`` whose loop has an eigenvalue outside the unit
circle, or a periodic/greedy switching of ``b`` whose period map does, :mod:`._refute`). Each
certified eps is its own certificate: it holds at that ``eps`` and at the design's own ``eps``
when ``certified`` says so, **not** at every eps in between. ``eps_star_certified`` and
``certified`` are those of the strongest coverage the data support (``b_rate``: None means
``b`` varies arbitrarily, the paper's ``b(k) = b(w(k), x(k))``). ``eps_star_frozen`` is the
largest eps below which every frozen loop with ``b`` on an ``n_b``-point grid of the interval
(ends included) is Schur, from a log-spaced scan refined to ``rtol / 10`` (secant steps,
bracket kept): an eigenvalue scan, not a certificate. For ``b < 0`` the design's ``gamma`` is
read as ``-|gamma|`` (the surrogate depends on ``b gamma`` only and is evaluated with ``|b|``
and ``|gamma|``; a :class:`~fl_design.DynamicController` stores ``gamma`` of the sign of ``b``).

Examples
--------
>>> import fl_design as fl
>>> cert = fl.certify_eps(fl.presets.paper_design(), (3.6, 6.8), search=False)
>>> cert.certified, cert.covers, cert.point.kind
(True, 'varying', 'common')
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import _validate as V
from ..errors import CertificationError, ParameterError
from ._cert_loop import _Loop, _serial  # (importers of _certify._Loop keep working)
from ._cert_results import EpsCertificate, class_fields
from ._class_bracket import class_brackets
from ._class_resolve import resolve_class
from ._coverage import coverage_brackets, coverage_of, gamma_fix
from ._ldi import loop_covered_set
from ._search import frozen_bracket, stable_intervals

if TYPE_CHECKING:  # annotations only (no import at run time)
    from ..design import Design

DEFAULT_EPS_RANGE = (1e-3, 1.0)


def _eps_range(eps_range) -> tuple[float, float]:
    lo, hi = V.interval("eps_range", eps_range, allow_none=False)
    if lo <= 0.0:
        raise ParameterError(f"eps_range must satisfy 0 < lo < hi, got ({lo}, {hi})")
    return lo, hi


@_serial
def certify_eps(design: Design, b_bounds, *, a_jacobian_bounds=None, b_rate=None,
                eps_range=DEFAULT_EPS_RANGE, n_b: int = 41, max_pieces: int = 8,
                n_scan: int = 32, rtol: float = 1e-2, search: bool = True,
                raise_on_failure: bool = False, region_search: bool = False) -> EpsCertificate:
    """Certify the design's ``eps`` and bracket ``eps*`` for each coverage of ``b``.

    See :mod:`fl_design.analysis._certify` for the loop covered (the sampled *linear
    surrogate*: chain of integrators, ``b`` in ``b_bounds``, the design's ``T`` and ``gamma``)
    and :mod:`fl_design.analysis._coverage` for the coverages: ``frozen`` (each constant
    ``b``), ``varying`` (``b`` arbitrary in time, the paper's ``b(k) = b(w(k), x(k))`` with no
    more known), ``rate-bounded`` (``|b_(k+1) - b_k| <= b_rate``), ``nonlinear`` (with
    ``a_jacobian_bounds``: the linear differential inclusion of
    :func:`fl_design.analysis._ldi.ldi_point`). Every eps* is a bracket
    ``[certified, refuted]``: the refuted end is a counterexample found by the search (a
    constant ``b`` with an unstable loop, or a periodic/greedy switching of ``b``).

    Parameters
    ----------
    design : Design
        An EHGO design.
    b_bounds : PlantClass, Plant, PlantBounds or (float, float)
        The class certified (:mod:`._class_resolve`): a :class:`~fl_design.PlantClass`; a
        Plant (its class, ``PlantClass.from_plant`` at the design's ``T``: ``b``, the slopes
        of ``sigma`` and ``b``'s rate over its region, never the ``a = 0`` chain); the
        enclosures of :func:`fl_design.analysis.plant_bounds` over a parameter box (the class
        of every plant of the box, slopes included; ``params`` lists the ranges); or
        ``(b_min, b_max)`` of one strict sign: the named chain class ``PlantClass.chain``.
    a_jacobian_bounds : sequence of (float, float) or "plant", optional
        Bounds of ``d sigma/d x_i`` at the equilibrium input, i = 1..rho
        (``plant.jacobian_bounds()``): the certificate covers the nonlinear plant's LDI.
        ``"plant"``: those of the ``PlantBounds`` given as ``b_bounds``.
    b_rate : float or "plant", optional
        What is known of ``b`` along trajectories: None (default) arbitrary variation, ``0``
        constant, ``> 0`` at most ``b_rate`` per sample; ``"plant"``: the rate the
        ``PlantBounds`` derived from the plant (``b_rate_source`` of the result says how).
        Sets the headline coverage ``covers`` (the strongest these data support).
    eps_range : (float, float), optional
        Search interval of eps (default ``(1e-3, 1)``).
    n_b : int, optional
        Points of the ``b`` grid of the frozen check (default 41).
    max_pieces : int, optional
        Finest split of the ``b`` interval for parameter-dependent certificates (default 8).
    n_scan : int, optional
        Log-spaced scan points of the frozen search (default 32).
    rtol : float, optional
        Relative resolution of the certified and refuted bisections (default 1e-2; frozen
        eigenvalue scan: rtol/10).
    search : bool, optional
        False: certify the design's eps only (no eps* searches, no brackets).
    raise_on_failure : bool, optional
        Raise :class:`~fl_design.errors.CertificationError` instead of returning a result that
        is not certified.
    region_search : bool, optional
        Given a Plant whose class over its whole region is not certified, shrink the region
        around the operating point (:mod:`._class_region`; tens of seconds) and certify the
        class of the largest region that passes; the description names the region.

    Returns
    -------
    EpsCertificate

    Raises
    ------
    ParameterError
        Bad ``b_bounds`` (reversed, containing 0, mixed sign, non-finite), a bad ``b_rate``,
        a non-EHGO design.
    DesignMismatchError
        ``a_jacobian_bounds`` of another relative degree than the design's.

    Examples
    --------
    >>> import fl_design as fl
    >>> c = fl.certify_eps(fl.presets.paper_design(gamma=3e-3), (3.6, 6.8))
    >>> c.covers, c.certified, c.eps_star_certified <= c.bracket("varying").refuted
    ('varying', False, True)
    """
    lo, hi = _eps_range(eps_range)
    from ._class_region import class_screen, loop_maker

    mk = loop_maker(design, n_b, max_pieces, _Loop)
    gamma = abs(design.controller.gamma)
    r = resolve_class(b_bounds, b_rate, a_jacobian_bounds, design,
                      screen=(lambda c: class_screen(mk(c), gamma, lo, hi)) if region_search
                      else None)
    b_bounds, b_rate, a_jacobian_bounds = r.b_bounds, r.b_rate, r.a_jacobian_bounds
    params, rate_source, pb = r.params, r.rate_source, r.pb
    rtol = V.positive("rtol", rtol)
    n_scan = V.integer("n_scan", n_scan, minimum=2)
    if b_rate is not None:
        b_rate = V.nonnegative("b_rate", b_rate)
    L = _Loop(design, b_bounds, a_jacobian_bounds, n_b, max_pieces, mk.loop)
    L.b_rate = b_rate  # which switchings are members of the class (_class_bracket)
    covers = coverage_of(b_rate, L.box)
    eps, gamma = design.estimator.eps, abs(design.controller.gamma)  # b gamma > 0: magnitudes
    point = L.covered_point(eps, gamma, covers, b_rate)
    f = c_common = c_head = None
    brackets, intervals = (), ()
    if search:
        intervals = stable_intervals(lambda e: L.frozen_ok(e, gamma), lo, hi, 4 * n_scan,
                                     rtol / 10, lambda es: L.frozen_margins(es, gamma) < 0.0)
        fb = frozen_bracket(lambda e: L.screened_margin(e, gamma), lo, hi, n_scan, rtol / 10,
                            lambda es: L.frozen_margins(es, gamma))
        f = None if fb is None else fb[0]
        if L.box is not None:
            found = class_brackets(L, gamma, lo, fb, rtol)
            brackets = (found["frozen"], found["nonlinear"])
            c_head = found["nonlinear"].certified
        else:
            found, c_common = coverage_brackets(
                L, gamma, lo, fb, rtol, b_rate,
                None if not b_rate else (lambda e: L.frozen_ok(e, gamma) and
                                         L.rate_point(e, gamma, b_rate).certified))
            brackets = tuple(found.values())
            c_head = found[covers].certified
    reason = (f"eps = {eps:g} certified for its class ({covers} b, {point.kind}): "
              f"{point.reason}" if point.certified else
              f"eps = {eps:g} not certified for its class ({covers} b): {point.reason}")
    if search and c_head is None:
        reason += ("; no eps of the range is certified for the class" + (
            f" (its structure, {'; '.join(x.describe() for x in r.cls.structure)}, is what "
            "multiplier arguments use: fl.certify_step)" if r.cls.structure else ""))
    if search and not intervals:
        fix = gamma_fix(L, gamma, lo, hi, n=40 if L.box is None else 12)
        if L.box is not None and r.cls.source in ("stated", "log") and fix.startswith("no |"):
            raise ParameterError(
                f"a_slopes = {[list(p) for p in r.cls.a_slopes]}: no gain stabilizes every "
                f"corner of this slope box with the design's K and T ({fix}); valid: a box "
                "whose corner plants one gamma stabilizes (narrow it)")
        reason += f"; no eps of [{lo:g}, {hi:g}] gives a stable surrogate: {fix}"
    if intervals and intervals[0][0] > lo:
        reason += (f"; the frozen-stable eps form a band away from eps = {lo:g}: "
                   + ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in intervals))
    if raise_on_failure and not point.certified:
        raise CertificationError(reason)
    return EpsCertificate(
        eps=float(eps), gamma=L.sign * gamma, T=design.T, b_bounds=L.signed_bounds,
        eps_range=(lo, hi),
        eps_star_frozen=f, eps_star_common=c_common, eps_star_certified=c_head,
        certified=point.certified, point=point, n_b_grid=L.n_b,
        a_jacobian_bounds=None if L.box is None else tuple(map(tuple, L.box.tolist())),
        reason=reason, covers=covers, brackets=brackets, b_rate=b_rate,
        eps_intervals_frozen=intervals, params=params, b_rate_source=rate_source,
        covered_set=loop_covered_set(L, point, pb), **class_fields(r.cls))


__all__ = ["DEFAULT_EPS_RANGE", "certify_eps"]
