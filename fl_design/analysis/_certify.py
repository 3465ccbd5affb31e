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

**How a point is certified** (cheapest first): the frozen loops on the ``b`` grid must be
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

import dataclasses
import functools
import itertools
import math
from typing import TYPE_CHECKING

import numpy as np

from .. import _validate as V
from .._blas import serial_blas
from ..errors import CertificationError, ParameterError
from ._analytic import piecewise_modal
from ._cert_results import EpsCertificate, PointCertificate, class_fields
from ._class_bracket import class_brackets
from ._class_resolve import resolve_class
from ._coverage import coverage_brackets, coverage_of, gamma_fix, varying_point
from ._ldi import loop_covered_set
from ._lmi import balance_scaling, vertex_lmi
from ._rate import rate_lmi
from ._search import frozen_bracket, stable_intervals
from ._slow_fast import piecewise_slow_fast, slow_fast_coordinates
from ._surrogate import SurrogateLoop, b_interval, delta, jacobian_box, schur_margins

if TYPE_CHECKING:  # annotations only (no import at run time)
    from ..design import Design

DEFAULT_EPS_RANGE = (1e-3, 1.0)
#: Finest modal piece: the interval split in ``MODAL_SPLIT * max_pieces`` pieces at most.
MODAL_SPLIT = 8
#: Finest modal piece relative to ``b_min`` (b_max/b_min up to 100: narrow pieces near b_min).
MODAL_REL_WIDTH = 0.003
#: Smallest relative degree certified in slow-fast coordinates (:mod:`._slow_fast`).
TWO_SCALE_MIN_RHO = 2
#: ``solver`` of a closed-form (modal Lyapunov) certificate.
MODAL = "modal (NumPy)"
#: Pieces of the rate-bounded ``P(b)`` (:mod:`._rate`).
RATE_PIECES = 4


def _serial(func):
    """Run ``func`` with one OpenBLAS thread for the caller (:func:`serial_blas`).

    The work is thousands of tiny dense problems (observer discretizations, 7 x 7 eigenvalue
    problems): on a loaded machine each wake-up of the BLAS thread pool waits for a time slice
    (a 4 x 4 ``scipy.linalg.solve`` measured 9 ms with the default threads, 40 us with one).
    """
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with serial_blas():
            return func(*args, **kwargs)
    return wrapper


class _Loop:
    """The surrogate of one design over one ``b`` interval: frozen checks and certificates."""

    def __init__(self, design, b_bounds, a_jacobian_bounds, n_b: int, max_pieces: int,
                 loop=None):
        from ..design import EHGO

        if not isinstance(design.estimator, EHGO):
            raise ParameterError(
                f"certification needs an EHGO design (it searches over eps), got a "
                f"{type(design.estimator).__name__}"
            )
        self.b_lo, self.b_hi, self.sign = b_interval(b_bounds)
        self.box = jacobian_box(a_jacobian_bounds, design.rho)
        self.n_b = V.integer("n_b", n_b, minimum=2)
        self.max_pieces = V.integer("max_pieces", max_pieces, minimum=1)
        self.loop = SurrogateLoop(design) if loop is None else loop
        self.T, self.design = design.T, design
        self.b_grid = np.linspace(self.b_lo, self.b_hi, self.n_b)
        self._worst = 0  # the b index that failed last (screened_margin)
        self.pieces_hint = 1  # eps_star_curve starts from the split that worked last
        self.modal_hit = False  # a search skips the LMIs once a modal certificate was found
        self.delta_error = 0.0  # the rounding bound of the last _deltas' similarity
        # two time scales (rho >= 3, slow-fast coordinates): the modal P is skipped once an LMI
        # certified where it failed (its slow cluster is near-defective), and a search starts
        # from the pieces of b that worked last (search_ok)
        self.two_scale = design.rho >= TWO_SCALE_MIN_RHO
        self.lmi_hit = False
        self.pieces_edges = []  # the pieces of the last certificate of _pieces (two time scales)
        self.scs = True  # SCS after a Clarabel failure (the fast curve turns it off)
        self.b_rate = None  # the class's bound on b's change per sample (None: arbitrary)
        self.signed_bounds = ((self.b_lo, self.b_hi) if self.sign > 0
                              else (-self.b_hi, -self.b_lo))

    def frozen_margin(self, eps: float, gamma: float) -> float:
        """Largest :func:`schur_margins` over the b grid (and the a-corners): < 0 iff Schur."""
        worst = -math.inf
        for a_row in self._corners():
            M0, M1 = self.loop.parts(eps, gamma, a_row)
            D = delta(M0[None] + self.b_grid[:, None, None] * M1[None], self.T)
            m = float(np.max(schur_margins(D, self.T)))
            worst = max(worst, m if math.isfinite(m) else math.inf)
        return worst

    def screened_margin(self, eps: float, gamma: float) -> float:
        """:meth:`frozen_margin`, screened first on a few ``b`` (the ends and the last worst).

        A failing screen is a counterexample (some ``b`` of the grid is not Schur) and its
        margin, a lower bound of the grid's, is returned; otherwise the whole grid is
        evaluated, so a negative value is exactly :meth:`frozen_margin`'s. For the refinement
        of a scan, where half the points fail.
        """
        if self.box is not None:
            return self.frozen_margin(eps, gamma)
        M0, M1 = self.loop.parts(eps, gamma)
        idx = sorted({0, self.n_b - 1, self._worst})
        m = schur_margins(delta(M0[None] + self.b_grid[idx, None, None] * M1[None], self.T),
                          self.T)
        if not np.max(m) < 0.0:
            return float(np.max(m)) if np.all(np.isfinite(m)) else math.inf
        m = schur_margins(delta(M0[None] + self.b_grid[:, None, None] * M1[None], self.T),
                          self.T)
        self._worst = int(np.argmax(m))
        return float(np.max(m)) if np.all(np.isfinite(m)) else math.inf

    def frozen_margins(self, eps_values, gamma: float) -> np.ndarray:
        """:meth:`frozen_margin` at many eps (``gamma``: one, or one per eps): one stacked
        eigenvalue call."""
        if self.box is not None:
            from ._class_bracket import box_frozen_margins

            return box_frozen_margins(self, eps_values, gamma)
        M0, M1 = self.loop.parts_many(eps_values, gamma)
        M = M0[:, None] + self.b_grid[None, :, None, None] * M1[:, None]
        m = schur_margins(delta(M, self.T), self.T).max(axis=-1)
        return np.where(np.isfinite(m), m, np.inf)

    def frozen_ok(self, eps: float, gamma: float) -> bool:
        """Every frozen loop on the b grid (and the a-corners) is Schur."""
        return self.frozen_margin(eps, gamma) < 0.0

    def _corners(self):
        if self.box is None:
            return [None]
        grids = np.meshgrid(*self.box, indexing="ij")
        return np.stack([g.ravel() for g in grids], axis=1)

    def _deltas(self, eps, gamma, b_pair, structured: bool = True):
        """Balanced vertex deltas of ``b_pair`` and the map ``K`` back to the loop's
        coordinates (a certificate ``P_b`` of the returned deltas is ``K^T P_b K`` there).

        For ``rho >= 3`` (``structured``) the slow-fast coordinates of :mod:`._slow_fast`
        when the loop has two time scales; ``self.delta_error`` is then the bound on the
        similarity's rounding that every re-check of these deltas subtracts (else 0: the
        power-of-2 balancing is exact).
        """
        M0, M1 = self.loop.parts(eps, gamma)
        D = [delta(M0 + b * M1, self.T) for b in b_pair]
        self.delta_error = 0.0
        if structured and self.two_scale:
            sf = slow_fast_coordinates(D, self.design.rho)
            if sf is not None:
                self.delta_error = sf[2]
                return sf[0], sf[1]
        s = balance_scaling(D)
        return [x * s[None, :] / s[:, None] for x in D], np.diag(1.0 / s)

    def point(self, eps: float, gamma: float, *, common_only: bool = False,
              lmi: bool = True) -> PointCertificate:
        """Certificate at one eps: frozen pre-screen, modal P on pieces, then the LMIs.

        ``lmi=False`` stops after the closed-form candidates (a search that already has one).
        ``covers`` of the result: ``"varying"`` for one common P over the whole interval,
        ``"frozen"`` for P(b) on pieces, ``"nonlinear"`` for the LDI.
        """
        pc = self._point(eps, gamma, common_only=common_only, lmi=lmi)
        if not pc.certified:
            return pc
        covers = ("nonlinear" if pc.kind == "ldi" else
                  "varying" if pc.covers_time_varying_b else "frozen")
        return dataclasses.replace(pc, covers=covers)

    def covered_point(self, eps: float, gamma: float, covers: str,
                      b_rate: float | None = None) -> PointCertificate:
        """The certificate of coverage ``covers`` at one eps (a stronger one counts)."""
        if covers in ("varying", "rate-bounded"):
            pc = varying_point(self, eps, gamma, self.point(eps, gamma, common_only=True))
            if pc.certified or covers == "varying" or not self.frozen_ok(eps, gamma):
                return pc
            return self.rate_point(eps, gamma, b_rate)
        return self.point(eps, gamma)

    def rate_point(self, eps: float, gamma: float, db: float) -> PointCertificate:
        """Rate-bounded certificate: ``P(b)`` piecewise affine with ``|b+ - b| <= db``."""
        M0, M1 = self.loop.parts(eps, gamma)
        ok, margin, note = rate_lmi(lambda b: delta(M0 + b * M1, self.T), self.b_lo,
                                    self.b_hi, self.T, db, RATE_PIECES)
        return PointCertificate(
            float(eps), ok, "rate-bounded P(b)" if ok else None, RATE_PIECES if ok else 0,
            False, "CLARABEL", "see reason", margin, note,
            covers="rate-bounded" if ok else None)

    def _point(self, eps, gamma, *, common_only, lmi) -> PointCertificate:
        if self.box is not None:
            from ._class_bracket import member_refutation_point
            from ._ldi import ldi_point

            return member_refutation_point(self, eps, gamma) or ldi_point(self, eps, gamma)
        margin = self.frozen_margin(eps, gamma)
        if not margin < 0.0:
            return PointCertificate(
                float(eps), False, None, 0, False, None, "not solved", None,
                f"a frozen loop of the {self.n_b}-point b grid is not Schur (margin "
                f"{margin:.3g} >= 0): no Lyapunov function exists, no LMI solved")
        if not common_only and not (self.two_scale and self.lmi_hit and lmi):
            pc = self._modal(eps, gamma)
            if pc.certified or not lmi:
                return pc
        whole = (self.b_lo, self.b_hi)
        if not common_only and self.two_scale and self.pieces_edges:
            edges, self.pieces_edges = self.pieces_edges, []
            pc = self._pieces(eps, gamma, None, edges=edges)
            narrow = min(hi - lo for lo, hi, _ in edges) * self.max_pieces < (
                self.b_hi - self.b_lo) * (1 + 1e-9)
            if pc.certified or not narrow:
                return pc  # (a failure on pieces too narrow to halve: from scratch below)
        if not common_only and self.pieces_hint > 1:
            return self._pieces(eps, gamma, None, self.pieces_hint)
        if not common_only:
            sol, s = self._vertex(eps, gamma, whole, common=False)
            if sol.certified:
                return _point(eps, sol, "parameter-dependent", [(whole, sol, s)], False)
            if self.two_scale:  # a common P is a parameter-dependent one: not tried again
                return self._pieces(eps, gamma, sol)
        if common_only:
            pc = self._modal(eps, gamma, whole=True)
            if pc.certified:
                return pc
        sol, s = self._vertex(eps, gamma, whole, common=True)
        if not sol.certified and common_only:
            sol = self._common_modal_basis(eps, gamma, sol)
        if sol.certified or common_only:
            return _point(eps, sol, "common", [(whole, sol, s)], True)
        return self._pieces(eps, gamma, sol)

    def _common_modal_basis(self, eps, gamma, failed):
        """:func:`._analytic.common_p_in_modal_basis` of the ends' deltas, else ``failed``."""
        from ._analytic import common_p_in_modal_basis

        D = self._deltas(eps, gamma, (self.b_lo, self.b_hi))[0]
        return common_p_in_modal_basis(D, self.T, failed, self.delta_error)

    def _vertex(self, eps, gamma, b_pair, common):
        D, s = self._deltas(eps, gamma, b_pair)
        return vertex_lmi(D, self.T, common=common, fallback=self.scs,
                          delta_error=self.delta_error), s

    def _modal(self, eps, gamma, whole: bool = False) -> PointCertificate:
        """Closed-form modal P on adaptively halved pieces (:mod:`._analytic`); ``whole``:
        one P for the whole interval (a common P, no halving)."""
        width = (self.b_hi - self.b_lo) / (1 if whole else MODAL_SPLIT * self.max_pieces)
        if not whole:  # wide ranges: pieces down to a fixed *relative* width near b_min
            width = min(width, MODAL_REL_WIDTH * self.b_lo)
        if self.two_scale and self.design.rho >= 3:
            # near-repeated slow poles: a Lyapunov P per piece in the piece's own slow-fast
            # coordinates (returned in the loop's: K = identity below)
            M0, M1 = self.loop.parts(eps, gamma)
            done, margin, bad = piecewise_slow_fast(
                lambda a, b: [delta(M0 + a * M1, self.T), delta(M0 + b * M1, self.T)],
                self.b_lo, self.b_hi, self.T, self.design.rho, width)
            s = np.eye(self.loop.size)
        else:
            (Dlo, Dhi), s = self._deltas(eps, gamma, (self.b_lo, self.b_hi))
            span = self.b_hi - self.b_lo or 1.0
            dD = Dhi - Dlo
            done, margin, bad = piecewise_modal(
                lambda b: Dlo + (b - self.b_lo) / span * dD, self.b_lo, self.b_hi, self.T,
                width, lambda bs: Dlo + ((bs - self.b_lo) / span)[:, None, None] * dD,
                self.delta_error)
        if bad is not None:
            return PointCertificate(
                float(eps), False, None, 0, False, MODAL, "closed form", None,
                f"modal P: no certificate for b in [{bad[0]:.6g}, {bad[1]:.6g}] (pieces of "
                f"width >= {width:.3g})")
        done.sort(key=lambda p: p[0])
        one = len(done) == 1
        return PointCertificate(
            float(eps), True, "common" if one else "parameter-dependent", len(done), one,
            MODAL, "closed form", margin,
            f"modal Lyapunov P on {len(done)} sub-interval(s) of b, each re-checked in NumPy",
            tuple((a, b) for a, b, _, _ in done),
            tuple((s.T @ P @ s, s.T @ P @ s) for _, _, P, _ in done))

    def _pieces(self, eps, gamma, last, start: int = 1, edges=None) -> PointCertificate:
        """Parameter-dependent LMIs on pieces of b, halved where they fail: ``start`` equal
        pieces, or the pieces ``edges`` (``(lo, hi, common P first)`` covering the interval)."""
        width = (self.b_hi - self.b_lo) / self.max_pieces
        if edges is None:
            e = np.linspace(self.b_lo, self.b_hi, start + 1)
            edges = [(a, b, self.two_scale) for a, b in itertools.pairwise(e)]
        stack, done, forms = list(reversed(edges)), [], []
        while stack:
            lo, hi, common = stack.pop()
            # two time scales: a common P on the piece first (half the SDP's size and time),
            # unless that piece needed P(b) last time
            sol = self._vertex(eps, gamma, (lo, hi), common=True) if common else None
            if sol is None or not sol[0].certified:
                sol = self._vertex(eps, gamma, (lo, hi), common=False)
                common = False
            sol, s = sol
            if sol.certified:
                done.append(((lo, hi), sol, s))
                forms.append((lo, hi, common))
            elif hi - lo > width * (1 + 1e-9) and len(done) + len(stack) < 4 * self.max_pieces:
                mid = 0.5 * (lo + hi)
                stack += [(mid, hi, self.two_scale), (lo, mid, self.two_scale)]
            else:
                return PointCertificate(
                    float(eps), False, None, len(done), False, sol.solver, sol.solver_status,
                    sol.margin, f"no certificate for b in [{lo:.6g}, {hi:.6g}] (pieces of "
                    f"width >= {width:.3g}): {sol.note}"
                    + ("" if last is None else f"; common P: {last.note}"))
        if self.two_scale:
            self.pieces_edges = forms  # a search's next eps starts from these pieces
        return _point(eps, None, "parameter-dependent", done, False)

    def search_ok(self, eps: float, gamma: float) -> bool:
        """Certified at eps? Remembers what worked (modal, or the LMI split) for the next."""
        pc = self.point(eps, gamma, lmi=not self.modal_hit)
        if pc.certified and pc.solver == MODAL:
            self.modal_hit = True
        elif pc.certified:
            self.pieces_hint = 1 if pc.kind == "common" else max(1, 2 ** int(np.log2(pc.pieces)))
            self.lmi_hit = True
        return pc.certified


def _point(eps, sol, kind, parts, tv) -> PointCertificate:
    """A PointCertificate from one solution ``sol`` (or None: all ``parts`` certified)."""
    if sol is not None and not sol.certified:
        return PointCertificate(float(eps), False, None, 0, False, sol.solver,
                                sol.solver_status, sol.margin, sol.note)
    parts = sorted(parts, key=lambda p: p[0][0])
    sols = [p[1] for p in parts]
    lyap = []
    for _, sl, K in parts:
        Ps = [K.T @ P @ K for P in sl.P]
        lyap.append((Ps[0], Ps[-1]))
    note = (sol.note if sol is not None else
            f"parameter-dependent P on {len(parts)} sub-intervals of b, each re-checked in NumPy")
    return PointCertificate(
        float(eps), True, kind, len(parts), tv, "+".join(sorted({x.solver for x in sols})),
        sols[-1].solver_status, min(x.margin for x in sols), note,
        tuple(p[0] for p in parts), tuple(lyap))


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
