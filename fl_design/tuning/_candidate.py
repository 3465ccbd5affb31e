"""One candidate loop of :func:`fl_design.tune`, and the chosen loop's certified eps.

Each step that can fail has a documented fallback, and a failure that survives its fallbacks
is a sentence in ``tried`` (the candidate is dropped) or, for the chosen loop, an
:class:`~fl_design.errors.NoDesignError` naming the step:

* **gains** (:func:`fl_design.synthesize_gains`): a failure drops the candidate;
* **gamma interval** (:func:`fl_design.certify_gamma` at a probe eps): the probe eps goes down by
  4 from ``0.2 / d`` to ``2 T`` until some gamma gives a stable loop;
* **eps**: the smaller of the surrogate's frozen-b eps* (eigenvalue scan) and the real plant's
  linearized eps*; when the linearization fails (no closed-loop equilibrium found), the frozen
  eps* alone, and the reasons say so;
* **check** (:func:`~fl_design.tuning._check.check_candidate`): a step that does not converge
  drops the candidate;
* **certificate** of the chosen loop (:func:`certified_eps`): eps from
  ``min(frozen, linearized) / EPS_MARGIN`` down by 2 (at most :data:`EPS_TRIES` LMI solves, no
  eps* bisection: one certificate per tried eps), the first with a phase margin of at least
  :data:`MIN_PHASE_MARGIN` deg and a check meeting the objective; no eps with that margin:
  the first certified one, its margin flagged; none certified: the provisional eps stays,
  said NOT certified.

Examples
--------
>>> from fl_design.tuning._candidate import EPS_MARGIN, EPS_TRIES
>>> EPS_MARGIN, EPS_TRIES
(1.25, 4)
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._progress import Lines
from ..analysis import (
    certify_eps,
    certify_gamma,
    eps_star_curve,
    linearized_eps_star,
    synthesize_gains,
)
from ..design import EHGO, Design, DynamicController
from ..errors import FlDesignError
from ._check import check_candidate

#: eps is at most the smaller eps* (frozen-b scan, linearized plant) divided by this.
EPS_MARGIN = 1.25
#: eps values tried for the certificate: min eps* / EPS_MARGIN, then halved (one LMI each).
EPS_TRIES = 4
#: A phase margin (degrees, at the plant input, worst over the b-range) below this is flagged;
#: the eps search prefers an eps that reaches it.
MIN_PHASE_MARGIN = 30.0
CONVERGENT = ("converged", "converging")


class Setup:
    """What every candidate shares: plant, T, b-range, limits, reference, objective check."""

    def __init__(self, plant, rho, T, b_bounds, u_lim, r, accept=None, progress=False):
        self.plant, self.rho, self.T, self.b_bounds, self.u_lim, self.r = (
            plant, rho, T, b_bounds, u_lim, r)
        self.say = Lines("fl.tune", progress)  # one line per step on stderr, as progress says
        self.sign = math.copysign(1.0, b_bounds[0])
        self.bmax = max(abs(b) for b in b_bounds)
        self.bmin = min(abs(b) for b in b_bounds)
        #: ``accept(check) -> str | None``: why a check misses the objective (None: meets it)
        self.accept = accept or (lambda check: None)


def g_text(x) -> str:
    """A number for a sentence (``-`` for None or non-finite)."""
    return "-" if x is None or not np.isfinite(x) else f"{x:.4g}"


class _Window(NamedTuple):
    gamma_min: float | None
    gamma_max: float | None
    gamma_lower_bound: None
    reason: str


def _gamma_window(probe, b_bounds) -> _Window:
    """The admissible gamma interval at the probe's eps (the frozen-b eigenvalue scan of
    :func:`fl_design.certify_gamma`, 40 points, 21 b values), without its lower bound over eps
    nor its LMI (the fast rule needs neither; the chosen design's gamma is certified)."""
    from ..analysis._certify import _Loop
    from ..analysis._search import gamma_interval

    L = _Loop(probe, b_bounds, None, 21, 8)
    eps, gamma = probe.estimator.eps, abs(probe.controller.gamma)
    lo, hi = gamma_interval(lambda g: L.frozen_ok(eps, g), gamma, 1e-4 * probe.T / L.b_hi,
                            4.0 / L.b_hi, 40, 1e-3)
    return _Window(lo, hi, None, "" if lo is not None else
                   f"no gamma of the scan gives a stable loop at eps = {eps:g}")


def _gamma_interval(s: Setup, d: float, gains, tried: list, low: bool):
    """The coarse admissible gamma interval at a probe eps (down by 4 until one is found)."""
    g0 = 5.0 * d * s.T / s.bmin
    eps0, eps_hi = max(2.0 * s.T, 0.2 / d), max(10.0 / d, 20.0 * s.T)
    grid = np.geomspace(s.T / 2.0, eps_hi, 6)
    probe = Design(estimator=EHGO(rho=s.rho, eps=eps0, T=s.T),
                   controller=DynamicController(gains, s.sign * g0, u_limits=s.u_lim))
    while True:
        gc = (certify_gamma(probe, s.b_bounds, eps_grid=grid, n_scan=40, n_b=21) if low
              else _gamma_window(probe, s.b_bounds))
        if gc.gamma_min is not None:
            return probe, gc, grid, eps_hi
        if probe.estimator.eps <= 2.0 * s.T:
            tried.append(f"loop at {d:.3g} rad/s: no gamma down to eps = "
                         f"{probe.estimator.eps:.3g}: {gc.reason}")
            return None
        probe = probe.replace(eps=max(2.0 * s.T, probe.estimator.eps / 4.0))


def candidate(s: Setup, d: float, rule: str, tried: list,
              margin_needed: bool = False) -> dict | None:
    """One loop at decay ``d``: gains, gamma, a provisional eps and its check (None: dropped,
    the reason appended to ``tried``); with ``margin_needed``, dropped before the check when
    none of the eps :func:`certified_eps` would try has a phase margin of
    :data:`MIN_PHASE_MARGIN` deg."""
    s.say(f"loop at {d:.3g} rad/s ({rule} gamma): gains, gamma interval, eps* scans, check")
    try:
        syn = synthesize_gains(s.rho, decay=d)
    except FlDesignError as exc:
        tried.append(f"loop at {d:.3g} rad/s: gain synthesis failed: {exc}")
        return None
    found = _gamma_interval(s, d, syn.gains, tried, rule == "low")
    if found is None:
        return None
    probe, gc, grid, eps_hi = found
    g0 = 5.0 * d * s.T / s.bmin
    g_lo, g_hi = 2.0 * gc.gamma_min, gc.gamma_max / 1.25
    if rule == "low" and gc.gamma_lower_bound is not None:
        g_lo = 2.0 * max(gc.gamma_lower_bound, gc.gamma_min)
        g0 = g_lo
    gamma = min(max(g0, g_lo), g_hi) if g_lo <= g_hi else math.sqrt(gc.gamma_min * gc.gamma_max)
    probe = probe.replace(gamma=s.sign * gamma)
    eps_range = (s.T / 2.0, eps_hi)
    frozen = float(eps_star_curve(probe, s.b_bounds, [gamma], eps_range=eps_range,
                                  certified=False).eps_star_frozen[0])
    what = f"loop at {d:.3g} rad/s, gamma {s.sign * gamma:.3g}"
    eps_lin, lin_text = _linearized(s, probe, eps_range)
    if not np.isfinite(frozen) or eps_lin == 0.0:
        tried.append(f"{what}: no stable eps in [{s.T / 2:g}, {eps_hi:g}] s (frozen-b eps* "
                     f"{g_text(frozen)}, linearized {lin_text})")
        return None
    eps = min(frozen, eps_lin or math.inf) / 2.0
    design = probe.replace(eps=eps)
    if margin_needed:
        best = max(eps_margins(s, {"design": design, "frozen": frozen,
                                   "eps_lin": eps_lin}).values())
        if not best >= MIN_PHASE_MARGIN:
            tried.append(f"{what}: no eps tried has a phase margin >= {MIN_PHASE_MARGIN:g} deg "
                         f"(at most {best:.3g} deg)")
            return None
    check = check_candidate(s.plant, design, s.r)
    if check["status"] not in CONVERGENT:
        tried.append(f"{what}, eps {eps:.3g}: the check simulation is {check['status']} "
                     f"({check['response'].verdict()})")
        return None
    gamma_why = ("twice the larger of the certified lower bound over eps and the interval's "
                 "lower end" if rule == "low" else
                 f"5 d T / |b|_min = {s.sign * 5.0 * d * s.T / s.bmin:.3g}, the disturbance "
                 "estimate 5x the loop's rate")
    reasons = [
        (f"gains {tuple(round(k, 6) for k in syn.gains)} (synthesize_gains at decay {d:.3g}: "
         f"{'certified' if syn.certified else 'not certified'})"),
        (f"gamma = {s.sign * gamma:.4g} ({gamma_why}; sign of b; kept inside the admissible "
         f"interval [{gc.gamma_min:.4g}, {gc.gamma_max:.4g}] at eps {probe.estimator.eps:.3g};"
         f" lower bound over eps {g_text(gc.gamma_lower_bound)}; paper bound 1/|b|_max = "
         f"{1 / s.bmax:.3g})"),
        f"u_limits = {s.u_lim}"]
    return dict(check, design=design, decay=d, gains=syn, eps_lin=eps_lin, frozen=frozen,
                lin=lin_text, grid=grid, reasons=reasons)


def _linearized(s: Setup, probe, eps_range) -> tuple[float | None, str]:
    """``(eps_lin, text)``: the real plant's linearized eps* (None: stable on the whole range;
    0.0: nowhere stable); when the loop's equilibrium cannot be found, None and the reason
    (the fallback: the frozen-b eps* alone)."""
    try:
        lin = linearized_eps_star(s.plant, probe, eps_range=eps_range, rtol=1e-3)
    except FlDesignError as exc:
        return None, f"not computed ({str(exc).splitlines()[0][:160]}; the frozen-b eps* alone)"
    if lin.value is None and not lin.above_range:
        return 0.0, str(lin)
    return (None if lin.above_range else float(lin.lower)), str(lin)


def certified_eps(s: Setup, c: dict) -> tuple[dict, str, object, float]:
    """The chosen loop's eps: the largest of ``min eps* / EPS_MARGIN`` halved up to
    ``EPS_TRIES - 1`` times whose LMI certificate holds, whose phase margin is at least
    :data:`MIN_PHASE_MARGIN`, and whose check converges and meets the objective (the margins
    are computed first, cheaply: the eps that have one are certified first, largest first;
    when none has it, the one with the largest margin first).

    Returns ``(candidate, reason, EpsCertificate at that eps, phase margin)``. When no eps
    has the margin, the first certified one whose check passes (its margin is flagged by the
    caller). Two uncertified eps in a row end the search (smaller ones fare no better on the
    loops seen, and each failed solve is the slowest step); then the smallest tried eps whose
    check passes stays, NOT certified, with the certificate already computed there (else the
    provisional eps), and the reason says so.
    """
    base = f"frozen-b eps* {g_text(c['frozen'])} (eigenvalue scan), linearized eps* {c['lin']}"
    provisional = c["design"].estimator.eps
    margins = eps_margins(s, c)  # cheap: the eps with the margin are certified first
    order = sorted(margins, key=lambda e: (0, -e) if margins[e] >= MIN_PHASE_MARGIN else
                   (1, -np.nan_to_num(margins[e], nan=-np.inf)))  # else the best margin first
    misses, spare, failed = [], None, []
    for k, eps in enumerate(order):
        trial = c["design"].replace(eps=eps)
        if spare is not None and not margins[eps] >= MIN_PHASE_MARGIN:
            break  # a certified, checked eps is in hand and no eps left has the margin
        s.say(f"loop at {c['decay']:.3g} rad/s: eps certificate {k + 1}/{EPS_TRIES} at eps = "
              f"{eps:.4g} s (one LMI; phase margin {margins[eps]:.3g} deg)")
        cert = _point(trial, s)
        if cert is None or not cert.certified:
            misses.append(f"{eps:.4g} not certified" + ("" if cert is None else
                                                        f" ({cert.reason})"))
            failed.append((trial, cert))
            if len(failed) == 2 and spare is None:  # two in a row: halving will not help
                break
            continue
        pm = margins[eps]
        low = not pm >= MIN_PHASE_MARGIN
        if low and spare is not None:
            misses.append(f"{eps:.4g} certified, phase margin {pm:.3g} deg")
            continue
        try:
            check = check_candidate(s.plant, trial, s.r)
        except FlDesignError as exc:  # a failed check is a miss of this eps, said
            misses.append(f"{eps:.4g} certified but its check failed: {str(exc)[:120]}")
            continue
        miss = s.accept(check) if check["status"] in CONVERGENT else \
            f"the check is {check['status']}"
        if miss:
            misses.append(f"{eps:.4g} certified but {miss}")
            continue
        halved = round(math.log2(max(margins) / eps))
        said = (f"eps = {eps:.4g} s (the smaller of the {base}, over {EPS_MARGIN:g}" +
                (f", halved {halved} time(s)" if halved else "") +
                (": " + "; ".join(misses) if misses else "") +
                (f"; larger eps have a phase margin below {MIN_PHASE_MARGIN:g} deg ("
                 + ", ".join(f"{e:.4g}: {m:.3g}" for e, m in margins.items() if e > eps) + ")"
                 if halved and not misses else "") + "; certified there, eps* not searched)")
        if low:  # certified and checked, but a small margin: kept in case none does better
            spare = (dict(c, **check, design=trial), said, cert, pm)
            misses.append(f"{eps:.4g} certified, phase margin {pm:.3g} deg")
            continue
        return dict(c, **check, design=trial), said, cert, pm
    if spare is not None:
        return spare[0], (spare[1] + f"; no eps tried has a phase margin >= "
                          f"{MIN_PHASE_MARGIN:g} deg: " + "; ".join(misses)), spare[2], spare[3]
    for trial, cert in failed[::-1] if cert_needed(failed) else ():  # the provisional eps
        try:  # an uncertified eps tried whose check converges: its certificate is in hand
            check = check_candidate(s.plant, trial, s.r)
        except FlDesignError:
            continue
        if check["status"] in CONVERGENT and not s.accept(check):
            eps = trial.estimator.eps
            return dict(c, **check, design=trial), (
                f"eps = {eps:.4g} s (from the smaller of the {base}, over {EPS_MARGIN:g}, "
                f"halved); NOT certified at any of the eps tried: {'; '.join(misses)}"), \
                cert, phase_margin(trial, s.b_bounds)
    cert = _point(c["design"], s)
    return c, (f"eps = {provisional:.4g} s (half the smaller of the {base}); NOT certified at "
               f"any of the eps tried: {'; '.join(misses)}"), cert, \
        phase_margin(c["design"], s.b_bounds)


def eps_margins(s: Setup, c: dict) -> dict:
    """``{eps: phase margin}`` over the eps :func:`certified_eps` tries, largest first."""
    top = min(c["frozen"], c["eps_lin"] or math.inf) / EPS_MARGIN
    return {top / 2.0 ** k: phase_margin(c["design"].replace(eps=top / 2.0 ** k), s.b_bounds)
            for k in range(EPS_TRIES)}


def cert_needed(failed) -> bool:
    """Every failed try has a certificate object (a solve that ran, not one that raised)."""
    return all(cert is not None for _, cert in failed)


def phase_margin(design, b_bounds, n_freq: int = 600) -> float:
    """The worst phase margin (deg) at the plant input over ``b_min``, ``b_max``.

    The loop of :func:`fl_design.analysis.loop_margins` (the surrogate cut at the plant
    input, :func:`fl_design.analysis._margins.open_loop`), its frequency response evaluated
    on a log grid up to Nyquist at once (batched linear solves), each gain crossover refined
    by bisection to 1e-9 relative; inf without a crossover, NaN when not computed.
    """
    from .._numerics import bisect_log
    from ..analysis._margins import open_loop

    out = []
    for b in b_bounds:
        try:
            A, B, C = open_loop(design, abs(b), None, abs(design.controller.gamma))
        except FlDesignError:
            continue
        T, eye = design.T, np.eye(A.shape[0])

        # batched solves: the EHGO's repeated poles are defective
        def L(w, A=A, B=B, C=C, T=T, eye=eye):
            z = np.exp(1j * np.atleast_1d(w) * T)
            sol = np.linalg.solve(z[:, None, None] * eye[None] - A[None],
                                  np.broadcast_to(B, (z.size, B.size))[..., None])[..., 0]
            return -(sol @ C)

        w = np.geomspace(1e-6 / T, math.pi / T, n_freq)
        mag = np.abs(L(w)) - 1.0
        pm = math.inf
        for i in np.flatnonzero(np.sign(mag[:-1]) != np.sign(mag[1:])):
            above = mag[i] > 0.0
            br = bisect_log(lambda x, a=above: bool((abs(L(x)[0]) > 1.0) == a), w[i], w[i + 1],
                            rtol=1e-9)
            x = math.sqrt(br.lo * br.hi)
            margin = (math.degrees(float(np.angle(L(x)[0]))) + 360.0) % 360.0 - 180.0
            pm = min(pm, margin, key=abs)
        out.append(float(pm))
    return min(out) if out else math.nan


def _point(design, s: Setup):
    """The LMI certificate at the design's eps (None: the solve failed, said by the caller)."""
    try:
        return certify_eps(design, s.b_bounds, search=False)
    except FlDesignError:
        return None


__all__ = ["CONVERGENT", "EPS_MARGIN", "EPS_TRIES", "MIN_PHASE_MARGIN", "Setup", "candidate",
           "certified_eps", "eps_margins", "g_text", "phase_margin"]
