"""The surrogate loop of one design over one ``b`` interval: frozen checks and certificates.

:class:`_Loop` holds the sampled linear surrogate (:mod:`._surrogate`) of a design for a ``b``
interval (and a-slope box) and answers, at one ``(eps, gamma)``: are the frozen loops of the
``b`` grid Schur (eigenvalues), and what certificate holds there, cheapest first: closed-form
modal ``P`` on pieces (:mod:`._analytic`, :mod:`._slow_fast`), then the vertex LMIs
(:mod:`._lmi`), each re-checked in NumPy. :func:`fl_design.certify_eps`
(:mod:`._certify`, which describes what a certificate covers) and the curves and gain scans
(:mod:`._curve`, :mod:`._gamma`) search over eps with it.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.analysis._cert_loop import _Loop
>>> L = _Loop(fl.presets.paper_design(), (3.6, 6.8), None, 41, 8)
>>> pc = L.point(0.01, 1e-3)
>>> pc.certified, pc.covers  # P(b) on pieces of b: each constant b
(True, 'frozen')
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math

import numpy as np

from .. import _validate as V
from .._blas import serial_blas
from ..errors import ParameterError
from ._analytic import piecewise_modal
from ._cert_results import PointCertificate
from ._coverage import varying_point
from ._lmi import balance_scaling, vertex_lmi
from ._rate import rate_lmi
from ._slow_fast import piecewise_slow_fast, slow_fast_coordinates
from ._surrogate import SurrogateLoop, b_interval, delta, jacobian_box, schur_margins

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
        self._worst_ok = 0  # the same for frozen_ok (its own: screened_margin's values stay)
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
        # the n x n common LMI (faster, another P: the fast curve, whose P serves nothing else)
        self.reduced = False
        self.b_rate = None  # the class's bound on b's change per sample (None: arbitrary)
        # pairs of LDI vertex loops switched before its SDP (ldi_point's refute_pairs: a growing
        # switching answers "no common P" as the SDP would); a search sets it, and it is
        # turned off once the SDP is solved anyway (the switching did not refute)
        self.ldi_refute_pairs = 0
        self.signed_bounds = ((self.b_lo, self.b_hi) if self.sign > 0
                              else (-self.b_hi, -self.b_lo))

    def frozen_margin(self, eps: float, gamma: float) -> float:
        """Largest :func:`schur_margins` over the b grid (and the a-corners): < 0 iff Schur."""
        m = schur_margins(self._frozen_deltas(eps, gamma), self.T)
        return float(np.max(m)) if np.all(np.isfinite(m)) else math.inf

    def _frozen_deltas(self, eps: float, gamma: float) -> np.ndarray:
        """Delta matrices of the frozen loops, ``(corners, n_b, n, n)`` (one stack: one
        eigenvalue call for every corner and ``b``)."""
        D = []
        for a_row in self._corners():
            M0, M1 = self.loop.parts(eps, gamma, a_row)
            D.append(M0[None] + self.b_grid[:, None, None] * M1[None])
        return delta(np.stack(D), self.T)

    def screened_margin(self, eps: float, gamma: float) -> float:
        """:meth:`frozen_margin`, screened first on a few ``b`` (the ends and the last worst).

        A failing screen is a counterexample (some ``b`` of the grid is not Schur) and its
        margin, a lower bound of the grid's, is returned; otherwise the whole grid is
        evaluated, so a negative value is exactly :meth:`frozen_margin`'s. For the refinement
        of a scan, where half the points fail.
        """
        if self.box is not None:
            return self.frozen_margin(eps, gamma)
        return self._screened(self._frozen_deltas(eps, gamma), "_worst")

    def _screened(self, D: np.ndarray, last: str) -> float:
        """The largest :func:`schur_margins` of ``D`` (``(corners, n_b, n, n)``), screened on
        the ends of ``b`` and the ``b`` index kept in the attribute ``last`` (every corner): a
        failing screen returns its margin (a lower bound), else the whole grid's, and ``last``
        becomes its worst ``b``."""
        idx = sorted({0, self.n_b - 1, getattr(self, last)})
        m = schur_margins(D[:, idx], self.T)
        if np.max(m) < 0.0:
            m = schur_margins(D, self.T)
            setattr(self, last, int(np.argmax(np.max(m, axis=0))))
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
        """Every frozen loop on the b grid (and the a-corners) is Schur.

        Exactly ``frozen_margin(eps, gamma) < 0``, screened first on the ends of ``b`` and the
        ``b`` that failed last (every corner): a failing screen answers without the rest of the
        grid (half the points of a bisection fail).
        """
        return self._screened(self._frozen_deltas(eps, gamma), "_worst_ok") < 0.0

    def _corners(self):
        """The distinct corners of the slope box (rows ``a``, first occurrences in order), or
        ``[None]`` without a box (a degenerate range, e.g. ``(0, 0)``, gives one value)."""
        if self.box is None:
            return [None]
        grids = np.meshgrid(*self.box, indexing="ij")
        rows = np.stack([g.ravel() for g in grids], axis=1)
        first = np.unique(rows, axis=0, return_index=True)[1]
        return rows[np.sort(first)]

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

            pc = member_refutation_point(self, eps, gamma)
            if pc is not None:
                return pc
            pc = ldi_point(self, eps, gamma, refute_pairs=self.ldi_refute_pairs)
            if pc.solver_status != "not solved":  # the switching did not refute: an SDP ran
                self.ldi_refute_pairs = 0
            return pc
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
                return self._pieces(eps, gamma, sol, failed=whole)
        if common_only:
            pc = self._modal(eps, gamma, whole=True)
            if pc.certified:
                return pc
        sol, s = self._vertex(eps, gamma, whole, common=True)
        if not sol.certified and common_only:
            sol = self._common_modal_basis(eps, gamma, sol)
        if sol.certified or common_only:
            return _point(eps, sol, "common", [(whole, sol, s)], True)
        return self._pieces(eps, gamma, sol, failed=whole)

    def _common_modal_basis(self, eps, gamma, failed):
        """:func:`._analytic.common_p_in_modal_basis` of the ends' deltas, else ``failed``."""
        from ._analytic import common_p_in_modal_basis

        D = self._deltas(eps, gamma, (self.b_lo, self.b_hi))[0]
        return common_p_in_modal_basis(D, self.T, failed, self.delta_error)

    def _vertex(self, eps, gamma, b_pair, common):
        D, s = self._deltas(eps, gamma, b_pair)
        return vertex_lmi(D, self.T, common=common, fallback=self.scs,
                          delta_error=self.delta_error, reduced=self.reduced), s

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

    def _pieces(self, eps, gamma, last, start: int = 1, edges=None,
                failed=None) -> PointCertificate:
        """Parameter-dependent LMIs on pieces of b, halved where they fail: ``start`` equal
        pieces, or the pieces ``edges`` (``(lo, hi, common P first)`` covering the interval);
        the piece ``failed`` (both forms already failed there, ``last`` the answer) is halved
        without solving again."""
        width = (self.b_hi - self.b_lo) / self.max_pieces
        if edges is None:
            e = np.linspace(self.b_lo, self.b_hi, start + 1)
            edges = [(a, b, self.two_scale) for a, b in itertools.pairwise(e)]
        stack, done, forms = list(reversed(edges)), [], []
        while stack:
            lo, hi, common = stack.pop()
            if failed is not None and (lo, hi) == tuple(failed):
                sol, s = last, None
            else:
                # two time scales: a common P on the piece first (a smaller, faster SDP),
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
                    + ("" if last is None or last is sol else f"; common P: {last.note}"))
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




__all__ = ["MODAL", "MODAL_REL_WIDTH", "MODAL_SPLIT", "RATE_PIECES", "TWO_SCALE_MIN_RHO"]
