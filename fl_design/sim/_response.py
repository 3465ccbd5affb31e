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
import math
from dataclasses import dataclass, field

import numpy as np

from .._frames import ColumnFrame
from .._json import jsonable
from ._metrics import STATUS_NAMES, Status, metrics_from_summary
from ._status import MIN_CHANGE, T_SIGNIFICANT


@dataclass(frozen=True)
class Response(ColumnFrame):
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
    ((2000,), (2000, 2), ['decay_rate', 'decay_rate_se', 'divergence_time'])
    """

    _FRAME_INSTEAD = "to_csv columns"

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
    iae = property(lambda self: self.metrics["iae"], doc="Integral of ``|e|``.")
    input_rms = property(lambda self: self.metrics["input_rms"], doc="RMS of u.")
    input_tv = property(lambda self: self.metrics["input_tv"], doc="Total variation of u.")
    estimation_rms = property(lambda self: self.metrics["estimation_rms"],
                              doc="RMS estimation errors (rho + 1,).")
    tail_error = property(lambda self: self.metrics["tail_error"], doc="max ``|e|`` on the tail.")
    tail_amplitude = property(lambda self: self.metrics["tail_amplitude"],
                              doc="Peak-to-peak of e on the tail.")
    status = property(lambda self: self.metrics["status"],
                      doc="'converged', 'converging', 'oscillating', 'stalled', 'undecided', "
                          "'diverged' or 'solver_failed' (see fl_design.sim.Status).")
    bounded = property(lambda self: Status.from_label(self.status).bounded,
                       doc="Stayed within bounds (every status but diverged and solver_failed).")
    converged = property(lambda self: self.status == "converged",
                         doc="Within tolerance over the whole tail.")
    stable = property(lambda self: Status.from_label(self.status).convergent,
                      doc="Converging or converged: bounded with a shrinking error (Theorem 1).")
    time_to_tolerance = property(lambda self: self.metrics["time_to_tolerance"],
                                 doc="Estimated time until ``|e| <= tol`` (converging runs).")
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

    def columns(self) -> dict:
        """The trajectories as named 1-D columns: ``t``, ``r``, ``y``, ``ym``, ``u``,
        ``sigmahat``, ``sigma``, ``xhat1 ..``, ``y_d0 ..`` (their true values ``y^(i)``) and
        ``x1 ..`` (the plant states), in that order; NaN after a divergence.

        Returns
        -------
        dict of numpy.ndarray

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.presets.pendulum_design()
        >>> list(fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 0.05)).columns())[:7]
        ['t', 'r', 'y', 'ym', 'u', 'sigmahat', 'sigma']
        """
        cols = {name: np.asarray(getattr(self, name), dtype=float)
                for name in ("t", "r", "y", "ym", "u", "sigmahat", "sigma")}
        for i in range(self.xhat.shape[1]):
            cols[f"xhat{i + 1}"] = self.xhat[:, i]
        for i in range(self.coords.shape[1]):
            cols[f"y_d{i}"] = self.coords[:, i]
        for i in range(self.x.shape[1]):
            cols[f"x{i + 1}"] = self.x[:, i]
        return cols

    def to_csv(self, path=None, *, overwrite: bool = False) -> str:
        """The trajectories (:meth:`columns`) as CSV: a header line, then one row per sample.

        Numbers are written with ``repr`` precision (they read back exactly); NaN as ``nan``.

        Parameters
        ----------
        path : str or pathlib.Path, optional
            Where to write; default: only return the text.
        overwrite : bool, optional
            Replace an existing file (default: refuse, so no one's file is overwritten).

        Returns
        -------
        str
            The CSV text.

        Raises
        ------
        OutputPathError
            ``path`` exists and ``overwrite`` is False, or its folder does not exist.

        Examples
        --------
        >>> import fl_design as fl
        >>> resp = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(),
        ...                    fl.Scenario(0.1, 0.05))
        >>> resp.to_csv().splitlines()[0]
        't,r,y,ym,u,sigmahat,sigma,xhat1,xhat2,y_d0,y_d1,x1,x2'
        """
        from pathlib import Path

        cols = self.columns()
        # names are identifiers and numbers never hold a comma: no quoting needed; tolist()
        # gives Python floats (repr: shortest round-trip), 10x faster than a csv.writer fed
        # NumPy scalars
        rows = zip(*(map(repr, np.asarray(c, dtype=float).tolist()) for c in cols.values()))
        text = ",".join(cols) + "\n" + "".join(f"{','.join(row)}\n" for row in rows)
        if path is not None:
            from ..errors import OutputPathError

            target = Path(path)
            if not target.parent.is_dir():
                raise OutputPathError(f"cannot write {str(target)!r}: its folder does not exist")
            try:
                with target.open("w" if overwrite else "x", encoding="utf-8", newline="") as f:
                    f.write(text)
            except FileExistsError:
                raise OutputPathError(
                    f"{str(target)!r} exists; pass overwrite=True to replace it") from None
        return text

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
            Three axes: output and reference, input, ``sigma`` and its estimate.

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
            ``"<status>: <evidence>"``: the verdict with the numbers it rests on (error band,
            when it was entered, offset, overshoot).

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.presets.pendulum_design()
        >>> fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 20.0)).verdict()
        'converged: |e| <= 0.002 from t = 9.08 s, mean offset -4.4e-05; overshoot 0 %'
        """
        m = self.metrics
        window = self.duration / 2
        text = _reason(self.status, m, self.tol, window, self.duration, self.adaptive_duration)
        tau = float(self.summary.get("loop_tau_samples", 0.0)) * self.T
        if (self.status == "undecided" and 0.0 < window < tau and not m["reversals"] >= 2
                and "too short to judge" not in text):
            text = (f"undecided: too short to judge: |e| = {m['tail_error']:.3g} (band "
                    f"{self.tol:.3g}) over the last {window:.3g} s, shorter than the designed "
                    f"loop's time constant {tau:.3g} s (its gains); run at least {4 * tau:.3g} s")
        over = "" if np.isnan(m["overshoot"]) else f"; overshoot {m['overshoot']:.3g} %"
        exit_ = ("" if np.isnan(m["region_exit_time"]) else
                 f"; left the plant's region at t = {m['region_exit_time']:.3g} s")
        run = (f"; run of {self.duration:.4g} s chosen by the loop: {self.duration_reason}"
               if self.adaptive_duration else "")
        return text + (over if self.status != "diverged" else "") + exit_ + run

    def _repr_html_(self) -> str:
        """A short HTML table for Jupyter: status, verdict, overshoot, settling time."""
        settle = (f"{self.settling_time:.3g} s" if np.isfinite(self.settling_time) else
                  "not settled (still outside the band at the end)")
        return _html_table([("status", self.status), ("verdict", self.verdict()),
                            ("overshoot", f"{self.overshoot:.3g} %"),
                            ("settling time", settle),
                            ("run", f"{self.t.size} samples, T = {self.T:g} s"),
                            ("run length", f"{self.duration:.4g} s ({self.duration_reason})")])

    def __repr__(self) -> str:
        chosen = (f", adaptive duration={self.duration:.4g} s" if self.adaptive_duration
                  else "")  # a given duration: N and T say it, as before
        return (f"Response(N={self.t.size}, T={self.T:g}, status={self.status!r}, "
                f"overshoot={self.overshoot:.3g}%, settling_time={self.settling_time:.3g} s"
                f"{chosen})")


def _saturation(m) -> str:
    sat = m["saturated_fraction"]
    return f"; u at its limits {100 * sat:.0f} % of the time" if sat >= 0.01 else ""


def _reason(status: str, m: dict, tol: float, window: float, duration: float,
            adaptive: bool) -> str:
    """The one-line reason of ``status``, with the measurements of the run (module doc of
    :mod:`fl_design.sim._status`); ``window`` is the analysed last half of the run (s)."""
    band = tol + m["noise_floor"] / 2
    noisy = f" (tolerance {tol:.3g} + half the noise floor)" if m["noise_floor"] > 0 else ""
    trend = f"envelope {100 * m['envelope_change']:+.0f} % over the last {window:.3g} s"
    swings = (f"; swings of {m['oscillation_amplitude']:.3g} peak-to-peak, period "
              f"{m['oscillation_period']:.3g} s" if m["reversals"] >= 2 else "")
    sat = _saturation(m)
    pinned = m["saturated_fraction"] >= 0.5
    longer = ("u is pinned at its limits, a longer run will not change this" if pinned else
              f"a run of {3 * duration:.3g} s or more decides" if not adaptive else
              f"a duration above this run's {duration:.3g} s decides")
    rate, se = m["decay_rate"], m["decay_rate_se"]
    if status == "converged":
        ripple = (f"; ripple {m['tail_amplitude']:.2g} peak-to-peak at the noise level (floor "
                  f"{m['noise_floor']:.2g})" if m["tail_amplitude"] > tol else "")
        if np.isfinite(m["settling_time"]):
            return (f"converged: |e| <= {tol:.3g} from t = {m['settling_time']:.3g} s, mean "
                    f"offset {m['steady_state_error']:.2g}{ripple}")
        return (f"converged: mean offset {m['steady_state_error']:.2g} within +-{tol:.3g}, "
                f"|e| up to {m['tail_error']:.3g}{ripple}")
    if status == "converging":
        beyond = " (beyond this run)" if m["time_to_tolerance"] > duration else ""
        confident = (f", fit t = {-rate / se:.2g}: a slow decay, confident at 95 %"
                     if rate < T_SIGNIFICANT * se else "")
        where = (f"inside the band at the end (|e| <= {m['tail_error']:.3g} <= {band:.3g}) but "
                 f"still swinging {m['tail_amplitude']:.3g} peak-to-peak (more than "
                 f"{tol:.3g})" if m["tail_error"] <= band else
                 f"|e| = {m['tail_error']:.3g} > {band:.3g}{noisy} at the end")
        if m["tail_error"] <= band:  # the swings' size decides (the converged rule)
            limit = max(tol, m["noise_floor"])
            when = duration + math.log(max(m["tail_amplitude"], limit) / limit) / rate
            forecast = (f"swings within {limit:.3g} peak-to-peak at about t = {when:.3g} s"
                        f"{' (beyond this run)' if when > duration else ''}")
        else:
            forecast = f"within the band at about t = {m['time_to_tolerance']:.3g} s{beyond}"
        return (f"converging: {where}, "
                f"{trend} (time constant {1 / rate:.3g} s +- {100 * se / rate:.0f} %"
                f"{confident}){swings}; {forecast}{sat}")
    if status == "oscillating":
        return (f"oscillating: {m['reversals']:.0f} reversals, swings of "
                f"{m['oscillation_amplitude']:.3g} peak-to-peak (band {band:.3g}), period "
                f"{m['oscillation_period']:.3g} s; {trend}{sat}")
    if status == "stalled":
        reached = ("" if m["reached"] else "; never covered 90 % of the step")
        return (f"stalled: bounded, |e| up to {m['tail_error']:.3g} with mean offset "
                f"{m['steady_state_error']:.3g} (band {band:.3g}), not approaching the "
                f"reference ({trend}){reached}{sat}")
    if status == "undecided":
        if m["reversals"] >= 2:
            swing = (f"swings of {m['oscillation_amplitude']:.3g} peak-to-peak (period "
                     f"{m['oscillation_period']:.3g} s), {trend}")
            what = (f"{swing}: growing, a limit cycle or a divergence to come"
                    if m["envelope_change"] > 0 else
                    f"{swing}: decaying too little to tell from a limit cycle")
        elif m.get("input_moving", 0) and m["envelope_change"] <= MIN_CHANGE:
            return (f"undecided: too short to judge: |e| = {m['tail_error']:.3g} > {band:.3g} "
                    f"({trend}) while the controller still moves u "
                    f"({m['input_drift']:+.3g} over the last {window:.3g} s); run longer "
                    f"(at least {3 * duration:.3g} s){sat}")
        else:
            n = int(m["reversals"])
            what = (f"{trend} without a full swing ({n} reversal{'s' if n != 1 else ''}; "
                    f"fitted rate {-rate:.3g} +- {se:.2g} 1/s)")
            if m["envelope_change"] < -MIN_CHANGE and rate > 0:  # shrinking, not significantly
                what = (f"slow: {trend} without a full swing ({n} reversal"
                        f"{'s' if n != 1 else ''}), time constant about {1 / rate:.3g} s, "
                        f"longer than the run can confirm (fit t = {-rate / se:.2g}; a swing "
                        f"slower than the window dips |e| where it crosses the reference)")
        return f"undecided: |e| = {m['tail_error']:.3g} > {band:.3g}, {what}; {longer}{sat}"
    if status == "diverged":
        return (f"diverged at t = {m['divergence_time']:.3g} s (left the bounds or became "
                "non-finite)")
    return ("solver failed: cvodes gave up on a bounded state (not a verdict on the loop; try "
            "fl.RK4 or looser tolerances)")


def _html_table(rows) -> str:
    """``[(name, value), ...]`` as a two-column HTML table, escaped."""
    import html

    cells = "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th>"
                    f"<td style='text-align:left'>{html.escape(str(v))}</td></tr>"
                    for k, v in rows)
    return f"<table>{cells}</table>"


__all__ = ["Response"]
