"""The result of one closed-loop simulation, its metrics, and the classification of runs.

Metrics (``e = y - r`` on the *true*, noise-free output; samples ``k = 0 .. N-1``, ``t = kT``;
``step = r_(N-1) - y_0``; ``tol = tolerance * scale`` with ``scale = max(|step|,
peak-to-peak of r)``, or 1 output unit when both vanish):

============================ ==================================================================
``overshoot``                ``100 * max(0, max_k sign(step) e_k) / |step|`` in % (NaN if
                             ``step == 0``); for a step reference the classical overshoot
``rise_time``                ``t90 - t10``: first times the output has covered 10 % and 90 % of
                             the step from ``y_0`` (NaN if never, or ``step == 0``)
``settling_time``            ``(k + 1) T`` for the last ``k`` with ``|e_k| > tol`` (0 if never;
                             NaN if still outside at the last sample)
``steady_state_error``       mean of ``e`` over the tail (the last ``tail_fraction`` of the run)
``iae``                      ``T sum |e_k|``
``input_rms``                ``sqrt(mean u_k^2)``
``input_tv``                 total variation ``sum_(k>=1) |u_k - u_(k-1)|``
``estimation_rms``           RMS of ``xhat_i - y^(i-1)`` (i = 1..rho) and of ``sigmahat - sigma``
``tail_error``               ``max |e|`` over the tail
``tail_amplitude``           ``max e - min e`` over the tail (= peak-to-peak of ``y`` for a
                             constant reference there)
``divergence_time``          time of the first sample out of bounds / non-finite (NaN if none)
============================ ==================================================================

Classification (the same for :func:`fl_design.simulate` and :func:`fl_design.sweep`):

* **diverged**: at some sample the plant state left ``|x - x_op| <= divergence_bound`` or a
  state or the input became non-finite (NaN, inf, finite escape); the run is stopped there;
* **stable**: not diverged, ``tail_error <= tol`` and ``tail_amplitude <= tol``;
* **undecided**: otherwise (still converging, or a sustained oscillation that stays bounded).

All other metrics of a diverged run are NaN.

Examples
--------
>>> import fl_design as fl
>>> design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
...                    controller=fl.DynamicController((2, 4), 1e-2))
>>> resp = fl.simulate(fl.plants.pendulum(), design, 0.1, 20.0)
>>> resp.status, round(resp.settling_time, 2), round(resp.overshoot, 3)
('stable', 9.08, 0.0)
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

#: Integer codes of the classification (``StabilityMap.status`` holds these).
STATUS_CODES = {"diverged": -1, "undecided": 0, "stable": 1}
STATUS_NAMES = {code: name for name, code in STATUS_CODES.items()}

METRIC_NAMES = ("overshoot", "rise_time", "settling_time", "steady_state_error", "iae",
                "input_rms", "input_tv", "estimation_rms", "tail_error", "tail_amplitude",
                "divergence_time")


def classify(summary: dict) -> np.ndarray:
    """Status codes (``STATUS_CODES``) from running sums (arrays broadcast).

    Parameters
    ----------
    summary : dict
        At least ``diverged``, ``tail_abs_e_max``, ``tail_e_max``, ``tail_e_min``, ``tol``.

    Returns
    -------
    numpy.ndarray of int

    Examples
    --------
    >>> from fl_design.sim import classify
    >>> classify(dict(diverged=0, tail_abs_e_max=0.001, tail_e_max=0.001, tail_e_min=0.0,
    ...               tol=0.01)).tolist()
    1
    """
    div = np.asarray(summary["diverged"]) != 0
    tol = np.asarray(summary["tol"])
    with np.errstate(invalid="ignore"):
        converged = (np.asarray(summary["tail_abs_e_max"]) <= tol) & (
            np.asarray(summary["tail_e_max"]) - np.asarray(summary["tail_e_min"]) <= tol)
    return np.where(div, -1, np.where(converged, 1, 0)).astype(int)


def metrics_from_summary(summary: dict, T: float) -> dict[str, np.ndarray]:
    """The metrics of the module table from running sums; arrays of any shape broadcast.

    ``summary`` holds the accumulator fields of :func:`fl_design.sim.accumulator_layout`
    (``N k_tail step tol diverged k_div e_max e_min abs_e_sum u2_sum du_sum est2_sum
    tail_abs_e_max tail_e_max tail_e_min tail_e_sum k10 k90 k_out``); ``est2_sum`` has a
    trailing axis of length ``rho + 1``.

    Parameters
    ----------
    summary : dict
        Running sums.
    T : float
        Sampling time.

    Returns
    -------
    dict
        ``METRIC_NAMES`` -> arrays (``estimation_rms`` with the trailing axis), plus ``status``.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim import metrics_from_summary
    >>> s = dict(N=10, k_tail=8, step=1.0, tol=0.02, diverged=0, k_div=-1, e_max=0.1,
    ...          e_min=-1.0, abs_e_sum=2.0, u2_sum=10.0, du_sum=1.0, est2_sum=np.zeros(3),
    ...          tail_abs_e_max=0.01, tail_e_max=0.01, tail_e_min=0.0, tail_e_sum=0.01,
    ...          k10=1, k90=3, k_out=5)
    >>> m = metrics_from_summary(s, 0.1)
    >>> [round(float(m[k]), 12) for k in ("overshoot", "rise_time", "settling_time")]
    [10.0, 0.2, 0.6]
    """
    g = {k: np.asarray(v, dtype=float) for k, v in summary.items()}
    N, step, div = g["N"], g["step"], g["diverged"] != 0
    astep = np.abs(step)
    n_tail = g["N"] - g["k_tail"]
    with np.errstate(invalid="ignore", divide="ignore"):
        peak = np.where(step > 0, g["e_max"], -g["e_min"])
        out = {
            "overshoot": np.where(astep > 0, 100.0 * np.maximum(0.0, peak) / astep, np.nan),
            "rise_time": np.where((astep > 0) & (g["k10"] >= 0) & (g["k90"] >= 0),
                                  (g["k90"] - g["k10"]) * T, np.nan),
            "settling_time": np.where(g["k_out"] >= N - 1, np.nan, (g["k_out"] + 1) * T),
            "steady_state_error": g["tail_e_sum"] / n_tail,
            "iae": g["abs_e_sum"] * T,
            "input_rms": np.sqrt(g["u2_sum"] / N),
            "input_tv": g["du_sum"],
            "estimation_rms": np.sqrt(g["est2_sum"] / N[..., None]),
            "tail_error": g["tail_abs_e_max"],
            "tail_amplitude": g["tail_e_max"] - g["tail_e_min"],
        }
    for name, value in out.items():
        mask = div[..., None] if name == "estimation_rms" else div
        out[name] = np.where(mask, np.nan, value)
    out["divergence_time"] = np.where(div, g["k_div"] * T, np.nan)
    out["status"] = classify(g)
    return out


def summary_from_trajectories(*, r, y, u, xhat, sigmahat, sigma, coords, y0: float,
                              step: float, tol: float, k_tail: int,
                              divergence_index: int | None) -> dict:
    """Running sums computed with NumPy from whole trajectories (the kernel's, independently).

    Samples ``k >= divergence_index - 1`` (NaN in a :class:`Response`) are left out, as in the
    kernel, which rejects the sample whose successor diverged.

    Parameters
    ----------
    r, y, u, sigmahat, sigma : array_like
        ``(N,)`` trajectories.
    xhat, coords : array_like
        ``(N, rho)`` estimates and true coordinates ``y^(i-1)``.
    y0, step, tol : float
        Initial output, step size, absolute tolerance.
    k_tail : int
        First tail sample.
    divergence_index : int or None
        Sample at which the run diverged.

    Returns
    -------
    dict

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim import summary_from_trajectories
    >>> z = np.zeros(4)
    >>> s = summary_from_trajectories(r=z, y=z, u=np.arange(4.0), xhat=np.zeros((4, 1)),
    ...     sigmahat=z, sigma=z, coords=np.zeros((4, 1)), y0=0.0, step=0.0, tol=0.1,
    ...     k_tail=3, divergence_index=None)
    >>> float(s["du_sum"]), float(s["u2_sum"])
    (3.0, 14.0)
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


@dataclass(frozen=True)
class Response:
    """One closed-loop run: trajectories, settings and metrics (module table).

    Samples after a divergence are NaN. Build it with :func:`fl_design.simulate`.

    Parameters
    ----------
    t, r, y, ym, u, sigmahat, sigma : numpy.ndarray
        ``(N,)``: times ``kT``, reference, true output, measured output (noise and
        quantization), input ``u_k`` (held over ``[kT, (k+1)T)``), estimate of ``sigma``, true
        ``sigma = y^(rho)`` under ``u_k``.
    xhat : numpy.ndarray
        ``(N, rho)`` estimates of ``y, y', ..., y^(rho-1)``.
    coords : numpy.ndarray
        ``(N, rho)`` their true values.
    x : numpy.ndarray
        ``(N, n)`` plant states.
    T : float
        Sampling time.
    tol : float
        Absolute tolerance of the classification and of the settling band.
    k_tail : int
        First sample of the tail window.
    y0, step : float
        Initial output and ``r_(N-1) - y0``.
    divergence_index : int or None
        First sample out of bounds or non-finite.
    method : str
        ``"rk4"`` or ``"cvodes"``.

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
    ...               controller=fl.DynamicController((2, 4), 1e-2))
    >>> resp = fl.simulate(fl.plants.pendulum(), d, 0.1, 2.0)
    >>> resp.y.shape, resp.xhat.shape, sorted(resp.metrics)[:3]
    ((2000,), (2000, 2), ['divergence_time', 'estimation_rms', 'iae'])
    """

    t: np.ndarray
    r: np.ndarray
    y: np.ndarray
    ym: np.ndarray
    u: np.ndarray
    xhat: np.ndarray
    sigmahat: np.ndarray
    sigma: np.ndarray
    coords: np.ndarray
    x: np.ndarray
    T: float
    tol: float
    k_tail: int
    y0: float
    step: float
    divergence_index: int | None = None
    method: str = "rk4"

    @functools.cached_property
    def metrics(self) -> dict:
        """All metrics (module table) and ``status``, as floats / a string / an array."""
        s = summary_from_trajectories(
            r=self.r, y=self.y, u=self.u, xhat=self.xhat, sigmahat=self.sigmahat,
            sigma=self.sigma, coords=self.coords, y0=self.y0, step=self.step, tol=self.tol,
            k_tail=self.k_tail, divergence_index=self.divergence_index)
        m = metrics_from_summary(s, self.T)
        out = {k: float(v) for k, v in m.items() if k not in ("estimation_rms", "status")}
        out["estimation_rms"] = np.asarray(m["estimation_rms"], dtype=float)
        out["status"] = STATUS_NAMES[int(m["status"])]
        return out

    overshoot = property(lambda self: self.metrics["overshoot"], doc="Overshoot in %.")
    rise_time = property(lambda self: self.metrics["rise_time"], doc="10-90 % rise time (s).")
    settling_time = property(lambda self: self.metrics["settling_time"], doc="Settling time (s).")
    steady_state_error = property(lambda self: self.metrics["steady_state_error"],
                                  doc="Mean error over the tail.")
    iae = property(lambda self: self.metrics["iae"], doc="Integral of |e|.")
    input_rms = property(lambda self: self.metrics["input_rms"], doc="RMS of u.")
    input_tv = property(lambda self: self.metrics["input_tv"], doc="Total variation of u.")
    estimation_rms = property(lambda self: self.metrics["estimation_rms"],
                              doc="RMS estimation errors (rho + 1,).")
    tail_error = property(lambda self: self.metrics["tail_error"], doc="max |e| on the tail.")
    tail_amplitude = property(lambda self: self.metrics["tail_amplitude"],
                              doc="Peak-to-peak of e on the tail.")
    status = property(lambda self: self.metrics["status"],
                      doc="'stable', 'undecided' or 'diverged'.")
    stable = property(lambda self: self.metrics["status"] == "stable", doc="Classified stable.")
    diverged = property(lambda self: self.divergence_index is not None, doc="Run diverged.")
    divergence_time = property(lambda self: self.metrics["divergence_time"],
                               doc="Time of divergence (NaN if none).")

    def to_dict(self) -> dict:
        """Trajectories (lists, NaN as None) and metrics, ready for JSON.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
        ...               controller=fl.DynamicController((2, 4), 1e-2))
        >>> sorted(fl.simulate(fl.plants.pendulum(), d, 0.1, 0.05).to_dict())[:4]
        ['T', 'coords', 'divergence_index', 'k_tail']
        """
        def clean(a):
            a = np.asarray(a, dtype=float)
            return np.where(np.isfinite(a), a, np.nan).astype(object).tolist() if a.ndim else (
                float(a) if np.isfinite(a) else None)

        def nan_none(v):
            if isinstance(v, list):
                return [nan_none(e) for e in v]
            return None if isinstance(v, float) and not np.isfinite(v) else v

        data = {name: nan_none(clean(getattr(self, name)))
                for name in ("t", "r", "y", "ym", "u", "xhat", "sigmahat", "sigma", "coords", "x")}
        metrics = {k: (nan_none(clean(v)) if k != "status" else v) for k, v in self.metrics.items()}
        data.update(T=self.T, tol=self.tol, k_tail=self.k_tail, y0=self.y0, step=self.step,
                    divergence_index=self.divergence_index, method=self.method, metrics=metrics)
        return data

    def plot(self, *, axes=None, title: str | None = None):
        """Output, input and sigma over time (:func:`fl_design.plotting.plot_response`).

        Parameters
        ----------
        axes : sequence of 3 matplotlib Axes, optional
            Where to draw; default a new figure.
        title : str, optional
            Figure title.

        Returns
        -------
        matplotlib.figure.Figure

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
        ...               controller=fl.DynamicController((2, 4), 1e-2))
        >>> fig = fl.simulate(fl.plants.pendulum(), d, 0.1, 0.5).plot()
        >>> len(fig.axes)
        3
        """
        from ..plotting import plot_response

        return plot_response(self, axes=axes, title=title)

    def __repr__(self) -> str:
        return (f"Response(N={self.t.size}, T={self.T:g}, status={self.status!r}, "
                f"overshoot={self.overshoot:.3g}%, settling_time={self.settling_time:.3g} s)")


__all__ = [
    "METRIC_NAMES",
    "STATUS_CODES",
    "STATUS_NAMES",
    "Response",
    "classify",
    "metrics_from_summary",
    "summary_from_trajectories",
]
