"""Independent NumPy re-computations shared by the tests (no fl_design code on the checked path).

* :func:`summary_from_trajectories`, :func:`metrics_from_trajectories`,
  :func:`status_from_trajectories`, :func:`region_exit_time`: a run's metrics and verdict
  computed from whole trajectories with NumPy, the twin of the kernel's running accumulators
  (:mod:`fl_design.sim._metrics`), written from the metric definitions, not from the table.
* :func:`surrogate_loop_matrix` (and helpers): the sampled linear surrogate loop of an EHGO
  design built by hand: the chain of ``rho`` integrators under exact zero-order hold
  (closed-form ``T^j / j!`` entries), ``sigma = b u``; the observer from the EHGO's own
  matrices ``(A_d, B_d)`` and ``(D^-1 C_d, D^-1 D_d)``; the controller law written out:
  ``z_k = z + T xhat_1``, ``v = -k_1 xhat_1 - sum k_i xhat_i - k_I z_k``,
  ``u_k = u + gamma (v - sigmahat)``. Loop state ``(x_1..x_rho, xi, u, z)``.
* :data:`B_TRMS`, :data:`GAINS`, :data:`KI`, :data:`T`, :func:`paper_ehgo`,
  :func:`paper_surrogate`: the paper's TRMS loop typed again (not read from
  :mod:`fl_design.presets`), for the certificate tests.
"""

from __future__ import annotations

import itertools
import math

import numpy as np


def summary_from_trajectories(*, r, y, u, xhat, sigmahat, sigma, coords, y0: float,
                              step: float, tol: float, k_tail: int,
                              divergence_index: int | None) -> dict:
    """Running sums computed with NumPy from whole trajectories.

    Samples ``k >= divergence_index - 1`` (NaN in a Response) are left out, as in the kernel,
    which rejects the sample whose successor diverged.
    """
    y, r, u = (np.asarray(a, dtype=float) for a in (y, r, u))
    N = y.size
    last = N if divergence_index is None else max(0, divergence_index - 1)
    e, uu = (y - r)[:last], u[:last]
    est = (np.column_stack([xhat, sigmahat]) - np.column_stack([coords, sigma]))[:last]
    tail = e[k_tail:]
    prog = np.sign(step) * (y[:last] - y0)
    first = lambda mask: float(np.argmax(mask)) if mask.any() else -1.0
    outside = np.flatnonzero(np.abs(e) > tol)
    return {
        "N": N, "k_tail": k_tail, "step": step, "tol": tol,
        "diverged": float(divergence_index is not None),
        "k_div": -1.0 if divergence_index is None else float(divergence_index),
        "e_max": e.max(initial=-np.inf), "e_min": e.min(initial=np.inf),
        "abs_e_sum": np.abs(e).sum(), "u2_sum": (uu * uu).sum(),
        "du_sum": np.abs(np.diff(uu)).sum(),
        "est2_sum": (est * est).sum(axis=0),
        "tail_abs_e_max": np.abs(tail).max(initial=0.0), "tail_e_max": tail.max(initial=-np.inf),
        "tail_e_min": tail.min(initial=np.inf), "tail_e_sum": tail.sum(),
        "k10": first(prog >= 0.1 * abs(step)), "k90": first(prog >= 0.9 * abs(step)),
        "k_out": float(outside[-1]) if outside.size else -1.0,
    }


def metrics_from_trajectories(resp) -> dict:
    """The metric definitions (module table of fl_design.sim._metrics) applied with NumPy."""
    s = summary_from_trajectories(
        r=resp.r, y=resp.y, u=resp.u, xhat=resp.xhat, sigmahat=resp.sigmahat, sigma=resp.sigma,
        coords=resp.coords, y0=resp.y0, step=resp.step, tol=resp.tol, k_tail=resp.k_tail,
        divergence_index=resp.divergence_index)
    T, N, step = resp.T, s["N"], s["step"]
    if s["diverged"]:
        nan = float("nan")
        out = {k: nan for k in ("overshoot", "rise_time", "settling_time", "steady_state_error",
                                "iae", "input_rms", "input_tv", "tail_error", "tail_amplitude",
                                "reversals", "oscillation_period", "decay_rate")}
        out["estimation_rms"] = np.full(np.shape(s["est2_sum"]), np.nan)
        out["divergence_time"] = s["k_div"] * T
        return out
    peak = s["e_max"] if step > 0 else -s["e_min"]
    ev = evidence_from_errors(resp.y - resp.r, k_tail=resp.k_tail, tol=resp.tol,
                              noise=resp.summary.get("noise", 0.0))
    return {
        "overshoot": 100.0 * max(0.0, peak) / abs(step) if step else float("nan"),
        "rise_time": ((s["k90"] - s["k10"]) * T if step and s["k10"] >= 0 and s["k90"] >= 0
                      else float("nan")),
        "settling_time": float("nan") if s["k_out"] >= N - 1 else (s["k_out"] + 1) * T,
        "steady_state_error": s["tail_e_sum"] / (N - s["k_tail"]),
        "iae": s["abs_e_sum"] * T,
        "input_rms": float(np.sqrt(s["u2_sum"] / N)),
        "input_tv": s["du_sum"],
        "estimation_rms": np.sqrt(s["est2_sum"] / N),
        "tail_error": s["tail_abs_e_max"],
        "tail_amplitude": s["tail_e_max"] - s["tail_e_min"],
        "reversals": ev["reversals"],
        "oscillation_period": ev["period"] * T,
        "decay_rate": -ev["rate"] / T,
        "divergence_time": float("nan"),
    }


def turning_points(e, h: float) -> list:
    """Turning points ``[(index, value), ...]`` of the zigzag of ``e`` with hysteresis ``h``.

    A zigzag leg starts once ``e`` has left the range of the samples so far by more than ``h``
    (upwards or downwards); each later move back by more than ``h`` from the leg's extreme ends
    the leg at a turning point (a reversal) and starts the next one.
    """
    values = [float(v) for v in e]
    points, top, bottom, trend = [], values[0], values[0], 0
    for i, v in enumerate(values[1:], 1):
        if trend == 0:
            top, bottom = max(top, v), min(bottom, v)
            if v < top - h:
                trend, bottom = -1, v
            elif v > bottom + h:
                trend, top = 1, v
        elif trend > 0:
            if v < top - h:
                points.append((i, top))
                trend, bottom = -1, v
            else:
                top = max(top, v)
        else:
            if v > bottom + h:
                points.append((i, bottom))
                trend, top = 1, v
            else:
                bottom = min(bottom, v)
    return points


def evidence_from_errors(e, *, k_tail: int, tol: float, noise: float = 0.0) -> dict:
    """The classifier's measurements recomputed from a whole error record ``e`` (NumPy and
    SciPy, no accumulator): window = second half, 8 blocks, reversals with hysteresis
    ``max(tol / 2, 4 noise)``, the envelope's log-linear fit by ``scipy.stats.linregress``."""
    from scipy.stats import linregress

    e = np.asarray(e, dtype=float)
    n = e.size
    k_mid = k_tail + (n - k_tail) // 2
    n_est = 2 * k_mid - k_tail
    start = math.floor(n_est / 2)
    length = (n_est - start) / 8
    k = np.arange(n)
    block = np.floor((k - start) / length)
    env = np.array([np.max(np.abs(e[(k >= start) & (block == j)])) for j in range(8)])
    h = max(0.5 * tol, 4.0 * noise)
    points = turning_points(e[start:], h)
    swings = [abs(b[1] - a[1]) for a, b in itertools.pairwise(points)]
    rev = len(points)
    period = 2 * (points[-1][0] - points[0][0]) / (rev - 1) if rev >= 2 else math.nan
    width = 1 if not rev >= 2 else int(min(max(math.ceil(period / 2 / length), 1), 6))
    smooth = np.array([env[i:i + width].max() for i in range(8 - width + 1)])
    centres = (np.arange(smooth.size) + width / 2) * length
    fit = linregress(centres, np.log(smooth))
    drops = -np.diff(smooth)
    heading = math.nan
    if smooth.size >= 4 and np.all(drops > 0):
        q = math.exp(np.polyfit(np.arange(drops.size), np.log(drops), 1)[0])
        heading = smooth[-1] - drops[-1] * q / (1 - q) if q < 1 else math.nan
    curvature = math.nan
    if smooth.size >= 5:
        x = centres - centres.mean()
        x = x / np.abs(x).max()
        X = np.column_stack([np.ones_like(x), x, x * x])
        coef, *_ = np.linalg.lstsq(X, np.log(smooth), rcond=None)
        var = max(float(np.sum((np.log(smooth) - X @ coef) ** 2)) / (smooth.size - 3), 1e-18)
        curvature = coef[2] / math.sqrt(var * np.linalg.inv(X.T @ X)[2, 2])
    return {"reversals": rev, "period": period, "curvature_t": curvature, "window_start": start,
            "spread": float(env.max() - env.min()), "top": float(env.max()),
            "amplitude": float(np.mean(swings)) if swings else math.nan,
            "swing_ratio": swings[-1] / swings[0] if len(swings) >= 2 else math.nan,
            "rate": fit.slope, "rate_se": fit.stderr,
            "change": math.expm1(fit.slope * length * (8 - width)), "band": tol + 4 * noise,
            "fit_points": smooth.size,
            "asymptote": heading,
            "floor": 8 * noise}


def status_from_trajectories(resp, noise: float | None = None) -> str:
    """The classification of :mod:`fl_design.sim._status` from the recorded trajectories
    (:func:`evidence_from_errors`), written again without the accumulators. ``noise``: the
    noise std (default: the run's own, from its summary)."""
    if noise is None:
        noise = float(resp.summary.get("noise", 0.0))
    if resp.divergence_index is not None:
        return "diverged"
    e = resp.y - resp.r
    tail = e[resp.k_tail:]
    ev = evidence_from_errors(e, k_tail=resp.k_tail, tol=resp.tol, noise=noise)
    if (np.abs(tail).max() <= ev["band"] and abs(tail.mean()) <= resp.tol
            and np.ptp(tail) <= max(resp.tol, ev["floor"])):
        return "converged"
    t = ev["rate"] / ev["rate_se"] if ev["rate_se"] > 0 else math.copysign(math.inf, ev["rate"])
    swinging = ev["reversals"] >= 2 and ev["amplitude"] > max(resp.tol, ev["floor"])
    offset = ev["asymptote"] > ev["band"] and not swinging
    if t < -4 and ev["change"] < -0.05 and not offset:
        return "converging"
    hump = abs(ev["curvature_t"]) > 4 and ev["spread"] > max(0.05 * ev["top"], ev["floor"])
    flat = (abs(t) < 1 or abs(ev["change"]) < 0.05) and not hump
    growing = t > 4 and ev["change"] > 0.05
    sustained = (ev["change"] >= -0.05 or ev["swing_ratio"] >= 0.95) and not growing
    if swinging and sustained:
        return "oscillating"
    half = e[ev["window_start"]:]
    one_sided = half.min() > -ev["band"] or half.max() < ev["band"]
    # a slower decay still counts when a one-sided 95 % Student interval of the fitted slope
    # (fit_points - 2 degrees of freedom) lies below zero, with the envelope down by more
    # than 5 %, no offset ahead, the input off its limits for at least half the window, and
    # the envelope a real one (e never crosses the band's far side, or two turning points)
    # that a straight line in log |e| describes (no hump)
    from scipy.stats import t as student

    dof = ev["fit_points"] - 2
    if (dof >= 1 and t < -student.ppf(0.95, dof) and ev["change"] < -0.05 and not offset
            and resp.metrics["saturated_fraction"] < 0.5
            and (one_sided or ev["reversals"] >= 2) and not hump):
        return "converging"
    # the input at rest: its mean over the window's last block against its first, beyond 10 %
    # of its level and its spread within those blocks, unsaturated, is a loop still moving
    kw = ev["window_start"]
    length = (e.size - kw) / 8
    block = np.floor((np.arange(kw, e.size) - kw) / length)
    first, last = resp.u[kw:][block == 0], resp.u[kw:][block == 7]
    drift = last.mean() - first.mean()
    moving = (abs(drift) > 0.1 * max(abs(first.mean()), abs(last.mean()))
              and abs(drift) > math.hypot(first.std(), last.std())
              and resp.metrics["saturated_fraction"] < 0.5)
    return ("stalled" if not swinging and (flat or offset) and one_sided and not moving
            else "undecided")


def region_exit_time(resp, region: dict, states) -> float:
    """First sample time at which the state is outside the declared region (NaN if never)."""
    outside = np.zeros(resp.t.size, dtype=bool)
    for i, s in enumerate(states):
        if s in region:
            lo, hi = region[s]
            outside |= (resp.x[:, i] < lo) | (resp.x[:, i] > hi)
    hits = np.flatnonzero(outside)
    return float(hits[0] * resp.T) if hits.size else float("nan")

def chain_zoh_closed_form(rho: int, T: float) -> tuple[np.ndarray, np.ndarray]:
    """``Phi_ij = T^(j-i)/(j-i)!`` (j >= i), ``Gamma_i = T^(rho-i+1)/(rho-i+1)!`` (1-based)."""
    Phi = np.zeros((rho, rho))
    for i in range(rho):
        for j in range(i, rho):
            Phi[i, j] = T ** (j - i) / math.factorial(j - i)
    Gam = np.array([T ** (rho - i) / math.factorial(rho - i) for i in range(rho)])
    return Phi, Gam


def surrogate_loop_matrix(ehgo, gains, gamma: float, ki: float, b: float) -> np.ndarray:
    """The ``(rho + (rho+1) + 2)``-square loop matrix of the surrogate at input gain ``b``."""
    rho, T = ehgo.rho, ehgo.T
    Ad, Bd, _, _ = ehgo.matrices
    Co, Do = ehgo.output_matrices()
    m = rho + 1
    n = rho + m + 2
    Px = np.hstack([np.eye(rho), np.zeros((rho, m + 2))])
    Pxi = np.hstack([np.zeros((m, rho)), np.eye(m), np.zeros((m, 2))])
    e1 = np.zeros((1, rho))
    e1[0, 0] = 1.0
    Y = e1 @ Px                                   # y_k = x_1
    Xh = Do.reshape(-1, 1) @ Y + Co @ Pxi         # xhat_1..xhat_rho, sigmahat
    eu, ez = np.eye(n)[rho + m], np.eye(n)[rho + m + 1]
    Z = ez + T * Xh[0]
    v = -gains[0] * Xh[0] - ki * Z
    for i in range(1, rho):
        v = v - gains[i] * Xh[i]
    U = eu + gamma * (v - Xh[rho])
    Phi, Gam = chain_zoh_closed_form(rho, T)
    return np.vstack([Phi @ Px + b * Gam[:, None] @ U[None, :],
                      Bd.reshape(-1, 1) @ Y + Ad @ Pxi, U[None, :], Z[None, :]])


#: The TRMS yaw's input-coefficient range and the paper's controller ``K``, ``k_I`` and sampling
#: time (the paper's values, typed here independently of :mod:`fl_design.presets`).
B_TRMS = (3.6, 6.8)
GAINS, KI, T = (2.0, 4.0), 1e-3, 1e-3


def paper_ehgo(eps: float):
    """The paper's observer at ``eps``: ``s^3 + 6 s^2 + 11 s + 6``, bilinear, ``T = 1 ms``."""
    import fl_design as fl

    return fl.EHGO(2, eps, T, coeffs=(6, 11, 6))


def paper_surrogate(eps: float, b: float, gamma: float = 3e-4) -> np.ndarray:
    """:func:`surrogate_loop_matrix` of the paper's TRMS loop at ``eps``, ``b`` and ``gamma``."""
    return surrogate_loop_matrix(paper_ehgo(eps), GAINS, gamma, KI, b)


def spectral_radius_over_b(ehgo, gains, gamma, ki, b_values) -> float:
    """Largest eigenvalue modulus (``numpy.linalg.eigvals``) over the given ``b`` values."""
    return max(float(np.max(np.abs(np.linalg.eigvals(
        surrogate_loop_matrix(ehgo, gains, gamma, ki, b))))) for b in b_values)


def sample_map(loop, r: float, p):
    """``X -> F(X)``: one sample of the loop's own CasADi sample function, ``X = (x, s)``."""
    n = loop.n

    def F(Z):
        x_next, s_next = loop.sample(Z[:n], Z[n:], r, 0.0, 0.0, p)[:2]
        return np.concatenate([np.asarray(x_next, float).ravel(),
                               np.asarray(s_next, float).ravel()])
    return F


def fd_jacobian(loop, X, r: float, p) -> np.ndarray:
    """Central differences of the sample map at ``X``, step 1e-7 of each component's scale (the
    TRMS friction tanh(w / 1e-3) has a third derivative ~1e9: at 1e-6 its truncation error is
    0.2 %)."""
    F = sample_map(loop, r, p)
    cols = []
    for j in range(X.size):
        h = 1e-7 * max(1.0, abs(X[j]))
        e = np.zeros(X.size)
        e[j] = h
        cols.append((F(X + e) - F(X - e)) / (2 * h))
    return np.column_stack(cols)
