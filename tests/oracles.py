"""Independent NumPy re-computations shared by the tests (no fl_design code on the checked path).

* :func:`summary_from_trajectories` and :func:`metrics_from_trajectories`: a run's metrics
  computed from whole trajectories with NumPy, the twin of the kernel's running accumulators
  (:mod:`fl_design.sim._metrics`), written from the metric definitions, not from the table.
"""

from __future__ import annotations

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
                                "iae", "input_rms", "input_tv", "tail_error", "tail_amplitude")}
        out["estimation_rms"] = np.full(np.shape(s["est2_sum"]), np.nan)
        out["divergence_time"] = s["k_div"] * T
        return out
    peak = s["e_max"] if step > 0 else -s["e_min"]
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
        "divergence_time": float("nan"),
    }


def status_from_trajectories(resp, shrink: float = 0.95) -> str:
    """The classification from whole trajectories: converged / converging / oscillating."""
    if resp.divergence_index is not None:
        return "diverged"
    e = resp.y - resp.r
    tail = e[resp.k_tail:]
    if np.abs(tail).max() <= resp.tol and np.ptp(tail) <= resp.tol:
        return "converged"
    half = (e.size - resp.k_tail) // 2
    first, second = np.abs(tail[:half]).max(), np.abs(tail[half:]).max()
    return "converging" if second < shrink * first else "oscillating"


def region_exit_time(resp, region: dict, states) -> float:
    """First sample time at which the state is outside the declared region (NaN if never)."""
    outside = np.zeros(resp.t.size, dtype=bool)
    for i, s in enumerate(states):
        if s in region:
            lo, hi = region[s]
            outside |= (resp.x[:, i] < lo) | (resp.x[:, i] > hi)
    hits = np.flatnonzero(outside)
    return float(hits[0] * resp.T) if hits.size else float("nan")
