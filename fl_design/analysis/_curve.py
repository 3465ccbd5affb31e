"""eps*(gamma): the frozen eigenvalue boundary and the frozen-b certificate along a gain scan.

Examples
--------
>>> import fl_design as fl
>>> c = fl.eps_star_curve(fl.presets.paper_design(), (3.6, 6.8), [1e-3])
>>> c.covers, bool(c.eps_star_certified[0] <= c.eps_star_frozen[0])
('frozen', True)
"""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING

import numpy as np

from .. import _validate as V
from .._progress import Lines
from ..errors import ParameterError
from ._cert_loop import _Loop, _serial
from ._cert_results import class_fields
from ._certify import DEFAULT_EPS_RANGE, _eps_range
from ._class_bracket import frozen_nan_reason, uncertified_words
from ._class_resolve import resolve_class
from ._curve_result import EpsStarCurve
from ._search import certified_eps_star, frozen_bracket

if TYPE_CHECKING:  # annotations only (no import at run time)
    from ..design import Design


@_serial
def eps_star_curve(design: Design, b_bounds, gammas, *, a_jacobian_bounds=None,
                   eps_range=DEFAULT_EPS_RANGE, n_b: int = 41, n_scan: int = 32,
                   rtol: float = 1e-2, max_pieces: int = 8,
                   certified: bool = True, time_budget: float | None = None,
                   progress="auto") -> EpsStarCurve:
    """Frozen and certified ``eps*`` against ``gamma`` (see :func:`certify_eps`).

    Continuation along the curve: the certified search at each gamma starts from the ratio
    found at the previous one (tries ``hint * eps*_frozen``, then steps down by 0.95).

    Parameters
    ----------
    design : Design
        An EHGO design (its structure; eps and gamma are varied).
    b_bounds : (float, float) or PlantBounds
        ``(b_min, b_max)`` of one strict sign, or :func:`fl_design.analysis.plant_bounds`.
    gammas : sequence of float
        Gains (> 0; magnitudes when ``b < 0``).
    a_jacobian_bounds : sequence of (float, float) or "plant", optional
        As in :func:`certify_eps`.
    eps_range : (float, float), optional
        Search interval of eps.
    n_b : int, optional
        Points of the b grid.
    n_scan : int, optional
        Scan points of the frozen search.
    rtol : float, optional
        Relative resolution of the certified bisection (frozen: rtol/10).
    max_pieces : int, optional
        As in :func:`certify_eps`.
    certified : bool, optional
        False: frozen curve only (certified entries NaN).
    time_budget : float, optional
        Seconds after which no more certified searches start: the later gains keep their
        frozen eps* (eigenvalues, fast) and a NaN certified entry, and ``uncovered`` names
        them (never a hang on a plant whose LMIs are slow). Default: no budget.
    progress : bool, "auto" or callable, optional
        ``progress(done, total)`` after each gain (a caller's progress line); ``True`` a line
        per gain on stderr, ``False`` none, ``"auto"`` (default) lines once the call has run
        2 s (:mod:`fl_design._progress`).

    Returns
    -------
    EpsStarCurve

    Examples
    --------
    >>> import fl_design as fl
    >>> c = fl.eps_star_curve(fl.presets.paper_design(), (3.6, 6.8), [1e-3, 3e-3])
    >>> bool(all(c.eps_star_certified <= c.eps_star_frozen))
    True
    """
    r = resolve_class(b_bounds, None, a_jacobian_bounds, design)
    b_bounds, a_jacobian_bounds = r.b_bounds, r.a_jacobian_bounds
    lo, hi = _eps_range(eps_range)
    rtol = V.positive("rtol", rtol)
    n_scan = V.integer("n_scan", n_scan, minimum=2)
    g = V.real_vector("gammas", gammas)
    if g.size == 0 or np.any(g <= 0):
        raise ParameterError(f"gammas must be a non-empty sequence of numbers > 0, got {g.tolist()}")
    if time_budget is not None:
        time_budget = V.nonnegative("time_budget", time_budget)
    tell = _teller(progress)
    L = _Loop(design, b_bounds, a_jacobian_bounds, n_b, max_pieces)
    L.scs = False  # the fast curve: Clarabel only (SCS took ~1 s per failed LMI)
    L.reduced = L.box is None  # and the n x n common LMI (its P serves nothing else)
    L.refute_points = False  # a slope box: no switching search at each eps (certificates only)
    # but the LDI's own vertex loops are switched first (2 pairs, ~40 ms): a growing period
    # proves the SDP infeasible (the TRMS's class: every gain, 16 SDPs of ~0.1 s saved)
    L.ldi_refute_pairs = 2
    # and the LDI's LMI first in its n x n form: no strictly feasible point there refutes the
    # point for one cheap SDP (the 2n form, whose P the contraction uses, only when it has one)
    L.ldi_screen = True
    # from 8 loop states on (rho >= 3) the LDI's LMI in its n x n form, without decay first:
    # measured on a rho 3 slope box, 0.07 s per solve against 0.36-0.44 s for the 2n form (12
    # gains 11.3 -> 2.7 s, the same 0/12 certified), rho 4: 21.9 -> 4.9 s (9 SDPs; the rest is
    # the frozen members' eigenvalues); below it the 2n form, whose P contracts better (rho 2
    # slope box: 9/12 gains certified against 8/12 with the n x n form)
    L.ldi_reduced_from = 8
    # two time scales (rho >= 3, slow-fast coordinates): the certificates reach the frozen
    # boundary (ratios 0.96-0.99 measured), the first search starts there
    frozen, cert = np.full(g.size, np.nan), np.full(g.size, np.nan)
    hint = 1.0 if L.two_scale else 0.9
    start, late, never = time.perf_counter(), [], []
    for i, gamma in enumerate(g):
        if i:
            tell(i, g.size)
        fb = frozen_bracket(lambda e, g_=gamma: L.screened_margin(e, g_), lo, hi, n_scan,
                            rtol / 10, lambda es, g_=gamma: L.frozen_margins(es, g_))
        if fb is None:  # unstable at the range's lower end: why (no eps at all, or a band)
            never.append(frozen_nan_reason(L, gamma, lo, hi))
            continue
        frozen[i] = f = fb[0]
        if (certified and time_budget is not None
                and time.perf_counter() - start > time_budget):
            late.append(float(gamma))
            continue
        if certified:
            L.modal_hit, L.pieces_hint = False, 1
            # a slope box's LDI is one SDP per eps (the chain's modal pieces are NumPy): a
            # coarser bisection (5 %), larger steps down, and no search below half its frozen
            # eps* (the descent ends there: not certified at half, the gain is skipped)
            box = L.box is not None
            floor = max(lo, 0.5 * f) if box else lo
            if box and not np.isfinite(cert[:i]).any() and not L.search_ok(floor, gamma):
                # no gain certified yet (the first, or a class failing throughout): one check
                # at the floor settles a failing gain in one SDP instead of a descent to it
                never.append(uncertified_words(gamma, floor, f, lo))
                continue
            c = certified_eps_star(lambda e, g_=gamma: L.search_ok(e, g_), floor, f,
                                   max(rtol, 0.05) if box else rtol, hint, 0.7 if box else 0.95,
                                   accelerate=True, retry=0.9)
            if c is not None:
                cert[i], hint = c, c / f
            else:
                never.append(uncertified_words(gamma, floor, f, lo))
    covers = "frozen" if L.box is None else "nonlinear"
    if covers == "frozen" and r.cls.b_rate != 0.0:
        # each constant b only: the class named is the one whose members hold b constant
        fields = class_fields(dataclasses.replace(r.cls, b_rate=0.0))
        varying = ("b varying in time, as the class allows: this curve certifies each constant "
                   "b; fl.certify_eps certifies b varying")
        fields["uncovered"] += (varying,)
    else:
        fields = class_fields(r.cls)
    if late:
        words = (f"the certified eps* at gamma = {', '.join(f'{x:.3g}' for x in late)}: not "
                 f"searched, the time budget of {time_budget:g} s was spent (NaN there means "
                 "not searched, not refuted)")
        fields["uncovered"] += (words,)
    fields["uncovered"] += tuple(never)
    tell(g.size, g.size)
    return EpsStarCurve(gamma=g, eps_star_frozen=frozen, eps_star_certified=cert,
                        b_bounds=L.signed_bounds, T=design.T, eps_range=(lo, hi),
                        covers=covers, **fields)


def _teller(progress):
    """``tell(done, total)`` of ``progress``: the caller's callable, or a line on stderr
    (:class:`fl_design._progress.Lines`) with the time to go."""
    if callable(progress):
        return progress
    say, t0 = Lines("fl.eps_star_curve", progress), time.perf_counter()

    def tell(done: int, total: int) -> None:
        if done < total:
            left = (time.perf_counter() - t0) * (total - done) / max(done, 1)
            say(f"{done}/{total} gains, about {left:.0f} s to go")

    return tell


__all__ = ["eps_star_curve"]
