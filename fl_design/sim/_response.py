"""The result of one closed-loop simulation: trajectories, metrics and status.

The metrics and the classification are those of :mod:`fl_design.sim._metrics` (one table,
shared with the sweep kernel): a :class:`Response` keeps the final accumulators of its run
(``summary``) and derives :attr:`Response.metrics` from them.

Examples
--------
>>> import fl_design as fl
>>> design = fl.presets.pendulum_design()
>>> resp = fl.simulate(fl.plants.pendulum(), design, fl.Scenario(0.1, 20.0))
>>> resp.status, round(resp.settling_time, 2), round(resp.overshoot, 3)
('converged', 9.08, 0.0)
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from .._json import jsonable
from ._metrics import STATUS_NAMES, Status, metrics_from_summary


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
    summary : dict
        The run's final accumulators and constants (:mod:`fl_design.sim._metrics`), from
        which :attr:`metrics` is derived.
    disturbance_start : float, optional
        When the scenario's first non-zero disturbance acts (``inf``: none).
    duration_reason : str, optional
        ``"given"`` (the scenario's ``duration``), or how the run chose its length
        (:mod:`fl_design.sim._duration`): the multiple of the loop's slowest time constant,
        clamped, or a fixed fallback, with the reason.

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.presets.pendulum_design()
    >>> resp = fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 2.0))
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
    summary: dict = field(default_factory=dict, repr=False, compare=False)
    duration_reason: str = "given"
    disturbance_start: float = float("inf")

    @property
    def disturbance(self) -> dict | None:
        """Response to the scenario's disturbance: ``disturbance_at`` (s), ``disturbance_peak``
        (max ``|y - r|`` from then on) and ``recovery_time`` (s until ``|y - r|`` stays
        within ``tol``; ``inf``: not within this run). None without a disturbance.

        Examples
        --------
        >>> import fl_design as fl
        >>> sc = fl.Scenario(0.1, 20.0, disturbance=fl.Disturbance(input=fl.Step(10.0, 0.5)))
        >>> resp = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), sc)
        >>> resp.disturbance["disturbance_at"], resp.disturbance["recovery_time"] < 10
        (10.0, True)
        """
        from ._disturbance import disturbance_metrics

        if not np.isfinite(self.disturbance_start):
            return None
        return disturbance_metrics(self.t, self.y, self.r, self.disturbance_start, self.tol)

    @property
    def duration(self) -> float:
        """Run length ``N T`` in seconds (as given, or chosen: see :attr:`duration_reason`)."""
        return self.t.size * self.T

    @property
    def adaptive_duration(self) -> bool:
        """The run chose its own length (the scenario gave no ``duration``)."""
        return self.duration_reason != "given"

    @functools.cached_property
    def metrics(self) -> dict:
        """All metrics (module table) and ``status``, as floats / a string / an array."""
        m = metrics_from_summary(self.summary, self.T)
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
                      doc="'converged', 'converging', 'oscillating', 'undecided', 'diverged' or "
                          "'solver_failed' (see fl_design.sim.Status).")
    bounded = property(lambda self: Status.from_label(self.status).bounded,
                       doc="Stayed within bounds (oscillating, converging, converged, undecided).")
    converged = property(lambda self: self.status == "converged",
                         doc="Within tolerance over the whole tail.")
    stable = property(lambda self: Status.from_label(self.status).convergent,
                      doc="Converging or converged: bounded with a shrinking error (Theorem 1).")
    time_to_tolerance = property(lambda self: self.metrics["time_to_tolerance"],
                                 doc="Estimated time until |e| <= tol (converging runs).")
    region_exit_time = property(lambda self: self.metrics["region_exit_time"],
                                doc="First time outside the plant's region (NaN if never).")
    diverged = property(lambda self: self.divergence_index is not None, doc="Run diverged.")
    divergence_time = property(lambda self: self.metrics["divergence_time"],
                               doc="Time of divergence (NaN if none).")

    def to_dict(self) -> dict:
        """Trajectories (lists, NaN as None) and metrics, ready for JSON.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.presets.pendulum_design()
        >>> data = fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 0.05)).to_dict()
        >>> sorted(data)[:4], data["duration"], data["duration_reason"]
        (['T', 'coords', 'disturbance', 'divergence_index'], 0.05, 'given')
        """
        data = {name: getattr(self, name)
                for name in ("t", "r", "y", "ym", "u", "xhat", "sigmahat", "sigma", "coords", "x")}
        data.update(T=self.T, tol=self.tol, k_tail=self.k_tail, y0=self.y0, step=self.step,
                    divergence_index=self.divergence_index, method=self.method,
                    duration=self.duration, duration_reason=self.duration_reason,
                    metrics=self.metrics, disturbance=self.disturbance)
        return jsonable(data)

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
        >>> d = fl.presets.pendulum_design()
        >>> fig = fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 0.5)).plot()
        >>> len(fig.axes)
        3
        """
        from ..plotting import plot_response

        return plot_response(self, axes=axes, title=title)

    def verdict(self) -> str:
        """One line saying what the run shows, with the numbers behind it.

        A run that chose its own length (no ``duration`` given) also says how long it ran and
        why.

        Returns
        -------
        str

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.presets.pendulum_design()
        >>> fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 20.0)).verdict()
        'converged: |e| <= 0.002 after 9.08 s; overshoot 0 %'
        """
        m, tol = self.metrics, self.tol
        tail = (self.t.size - self.k_tail) * self.T
        over = "" if np.isnan(m["overshoot"]) else f"; overshoot {m['overshoot']:.3g} %"
        exit_ = ("" if np.isnan(m["region_exit_time"]) else
                 f"; left the plant's region at t = {m['region_exit_time']:.3g} s")
        text = {
            "converged": f"converged: |e| <= {tol:.3g} after {m['settling_time']:.3g} s",
            "converging": (f"converging: |e| = {m['tail_error']:.3g} > {tol:.3g} at the end, "
                           f"shrinking; estimated within tolerance at t = "
                           f"{m['time_to_tolerance']:.3g} s (run longer to confirm)"),
            "oscillating": (f"oscillating: bounded, the error swings and its envelope does not "
                            f"shrink "
                            f"({m['tail_reversals']:.0f} reversals over the last {tail:.3g} s; "
                            f"tail |e| up to {m['tail_error']:.3g}, peak-to-peak "
                            f"{m['tail_amplitude']:.3g}, tolerance {tol:.3g})"),
            "undecided": (f"undecided: bounded, |e| = {m['tail_error']:.3g} > {tol:.3g} at the "
                          f"end, neither shrinking nor swinging over the last {tail:.3g} s: a "
                          f"mode slower than this run or a persistent offset; run longer "
                          + ("(give a duration longer than this run's)" if self.adaptive_duration
                             else "(omit the duration for one chosen from the loop's slowest "
                                  "mode)")),
            "diverged": f"diverged at t = {m['divergence_time']:.3g} s (left the bounds or "
                        "became non-finite)",
            "solver_failed": "solver failed: cvodes gave up on a bounded state (not a verdict "
                             "on the loop; try fl.RK4 or looser tolerances)",
        }[self.status]
        run = (f"; run of {self.duration:.4g} s chosen by the loop: {self.duration_reason}"
               if self.adaptive_duration else "")
        return text + (over if self.status != "diverged" else "") + exit_ + run

    def _repr_html_(self) -> str:
        """A short HTML table for Jupyter: status, verdict, overshoot, settling time."""
        return _html_table([("status", self.status), ("verdict", self.verdict()),
                            ("overshoot", f"{self.overshoot:.3g} %"),
                            ("settling time", f"{self.settling_time:.3g} s"),
                            ("run", f"{self.t.size} samples, T = {self.T:g} s"),
                            ("run length", f"{self.duration:.4g} s ({self.duration_reason})")])

    def __repr__(self) -> str:
        chosen = (f", adaptive duration={self.duration:.4g} s" if self.adaptive_duration
                  else "")  # a given duration: N and T say it, as before
        return (f"Response(N={self.t.size}, T={self.T:g}, status={self.status!r}, "
                f"overshoot={self.overshoot:.3g}%, settling_time={self.settling_time:.3g} s"
                f"{chosen})")


def _html_table(rows) -> str:
    """``[(name, value), ...]`` as a two-column HTML table, escaped."""
    import html

    cells = "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th>"
                    f"<td style='text-align:left'>{html.escape(str(v))}</td></tr>"
                    for k, v in rows)
    return f"<table>{cells}</table>"


__all__ = ["Response"]
