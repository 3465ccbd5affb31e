"""One home for a run's metrics and status: running accumulators and the metrics they give.

Every metric of a run is computed from a few running accumulators, updated once per accepted
sample inside the compiled closed-loop kernel (so a sweep keeps a few dozen numbers per grid
point, whatever the run length). Both tables live here and nothing else defines them: the
accumulator layout, the kernel's update (:func:`update`), :attr:`fl_design.Response.metrics`
and the :class:`fl_design.StabilityMap` are derived from them. Adding a metric is one entry in
:data:`ACCUMULATORS` (if it needs a new running value) and one in :data:`METRICS`.

Per-sample signals (``e = y - r`` on the *true*, noise-free output; samples ``k = 0 .. N-1``,
``t = kT``; ``step = r_(N-1) - y_0``; ``tol = tolerance * scale`` with ``scale = max(|step|,
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

``time_to_tolerance``        converging runs: estimated time from the start until ``|e|`` is
                             in the band, the tail's largest ``|e|`` decaying at the fitted
                             ``decay_rate`` from the run's end (NaN for other runs;
                             ``settling_time`` when converged)
``region_exit_time``         time of the first sample at which the plant state was outside its
                             declared region (NaN if never or no region): reported separately,
                             the loop may still converge
``reversals``                reversals of ``e`` over the analysis window (the run's second
                             half), with hysteresis ``max(tol / 2, 4 noise)``
``oscillation_period``       ``2 (k_last - k_first) T / (reversals - 1)`` (NaN under 2)
``oscillation_amplitude``    mean peak-to-peak of the swings between reversals
``decay_rate``               ``-slope`` (1/s) of ``log`` envelope fitted over the window
                             (:func:`~fl_design.sim._status.evidence`); ``decay_rate_se`` its
                             standard error; ``envelope_change`` the fitted relative change
``noise_floor``              ``NOISE_P2P * noise``: the peak-to-peak of noise-level ripple
``saturated_fraction``       fraction of the window with ``u`` at a limit of ``u_limits``
``input_drift``              mean ``u`` over the window's last block minus over its first: a
                             controller still moving its input has not come to rest;
                             ``input_moving`` 1 when it moved by more than ``U_DRIFT`` of its
                             level and more than its spread within those blocks (noise),
                             unsaturated (:mod:`fl_design.sim._status`)
``reached``                  1 if the output covered 90 % of the step at some time
============================ ==================================================================

Status (:class:`Status`, the same for :func:`fl_design.simulate` and :func:`fl_design.sweep`):
``diverged``, ``converged``, ``converging``, ``oscillating``, ``stalled``, ``undecided`` or
``solver_failed``; the rules are in :mod:`fl_design.sim._status`. All other metrics of a
diverged run are NaN.

Examples
--------
>>> from fl_design.sim import Status
>>> from fl_design.sim._metrics import METRICS
>>> [m.name for m in METRICS][:3], Status.CONVERGED.label
(['overshoot', 'rise_time', 'settling_time'], 'converged')
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..design import Layout
from ._status import (
    NBLOCKS,
    NOISE_P2P,
    REVERSAL_HYSTERESIS,
    STATUS_CODES,
    STATUS_NAMES,
    Status,
    classify,
    evidence,
)


@dataclass(frozen=True)
class Accumulator:
    """A running value of the kernel: its length, initial value and update per sample.

    Parameters
    ----------
    name : str
        Field name in the accumulator.
    initial : float
        Value before the first sample.
    update : callable
        ``update(prev, s) -> new`` on CasADi expressions, ``s`` the per-sample signals
        (:func:`signals`) and ``s["prev"]``, the previous values of every accumulator (for
        running values that depend on each other, such as the swing counter).
    per_estimate : bool, optional
        One entry per estimate ``rho + 1`` instead of a scalar.

    Examples
    --------
    >>> from fl_design.sim._metrics import ACCUMULATORS
    >>> next(a for a in ACCUMULATORS if a.name == "e_max").initial
    -inf
    """

    name: str
    initial: float
    update: Callable
    per_estimate: bool = False


def _tail(op):
    return lambda prev, s: _if(s["tail"], op(prev, s), prev)


def _if(c, a, b):
    import casadi as ca

    return ca.if_else(c, a, b)


def _fmax(a, b):
    import casadi as ca

    return ca.fmax(a, b)


def _fmin(a, b):
    import casadi as ca

    return ca.fmin(a, b)


def _fabs(a):
    import casadi as ca

    return ca.fabs(a)


def _window(s):
    """``(in_window, block)`` of this sample: the analysis window is the run's second half.

    The run length is recovered from the constants the signals carry (``N ~ 2 k_mid - k_tail``,
    exact or one short), the window starts at ``floor(N / 2)`` and is cut into
    :data:`~fl_design.sim._status.NBLOCKS` blocks of equal length (the same arithmetic as
    :func:`fl_design.sim._status.window_geometry`).
    """
    if "_window" not in s:
        import casadi as ca

        n = 2 * s["k_mid"] - s["k_tail"]
        kw = ca.floor(n / 2)
        length = (n - kw) / NBLOCKS
        s["_window"] = (s["k"] >= kw, ca.floor((s["k"] - kw) / length))
    return s["_window"]


def _swing(s):
    """``(direction, extremum, reversed)`` of the window's swing counter after this sample.

    ``rev_dir`` is 0 until ``e`` has left the range of the window so far
    (``win_e_min .. win_e_max``) by more than the hysteresis ``h``, then +1 (rising) or -1
    (falling); ``rev_ext`` is the running extremum of ``rev_dir * e`` (the largest ``e`` while
    rising, minus the smallest while falling). Moving back by more than ``h`` from it is a
    reversal: the direction flips and the extremum restarts at ``e``. ``h`` is the larger of
    ``REVERSAL_HYSTERESIS * tol`` and half the noise floor (:func:`noise_floor`): ripple at
    the noise level is not a swing. Before the window its extremes are still -inf / inf, so
    nothing starts: no gating needed, which keeps the kernel's step short.
    """
    if "_swing" not in s:  # once per sample, shared by the accumulators below
        p, e = s["prev"], s["e"]
        h = _fmax(REVERSAL_HYSTERESIS * s["tol"], 0.5 * NOISE_P2P * s["noise"])
        d, ext = p["rev_dir"], p["rev_ext"]
        idle = d == 0
        back = (1 - idle) * (d * e < ext - h)
        down, up = idle * (e < p["win_e_max"] - h), idle * (e > p["win_e_min"] + h)
        d_new = d * (1 - 2 * back) + up - down  # down and up never both hold
        s["_swing"] = (d_new, _if(back + down + up, d_new * e, _fmax(ext, d * e)), back)
    return s["_swing"]


def _on_reversal(op):
    """Update only on a reversal; ``op(prev, s, extremum)`` with the swing's extreme ``e``."""
    def update_(p, s):
        back = _swing(s)[2]
        extremum = s["prev"]["rev_dir"] * s["prev"]["rev_ext"]
        return _if(back, op(p, s, extremum), p)
    return update_


def _block(j, op, signal=lambda s: s["e"]):
    """Update with ``op(prev, signal(s))`` on the samples of block ``j`` of the window."""
    def update_(p, s):
        inside, block = _window(s)
        return _if(inside * (block == j), op(p, signal(s)), p)
    return update_


def _in_window(op):
    return lambda p, s: _if(_window(s)[0], op(p, s), p)


#: The running values of a run (order = accumulator order).
ACCUMULATORS = (
    Accumulator("e_max", -np.inf, lambda p, s: _fmax(p, s["e"])),
    Accumulator("e_min", np.inf, lambda p, s: _fmin(p, s["e"])),
    Accumulator("abs_e_sum", 0.0, lambda p, s: p + s["abs_e"]),
    Accumulator("u2_sum", 0.0, lambda p, s: p + s["u"] * s["u"]),
    Accumulator("du_sum", 0.0, lambda p, s: p + _if(s["k"] > 0, s["abs_du"], 0)),
    Accumulator("est2_sum", 0.0, lambda p, s: p + s["est_err"] * s["est_err"], per_estimate=True),
    Accumulator("tail_abs_e_max", 0.0, _tail(lambda p, s: _fmax(p, s["abs_e"]))),
    Accumulator("tail_e_max", -np.inf, _tail(lambda p, s: _fmax(p, s["e"]))),
    Accumulator("tail_e_min", np.inf, _tail(lambda p, s: _fmin(p, s["e"]))),
    Accumulator("tail_e_sum", 0.0, _tail(lambda p, s: p + s["e"])),
    Accumulator("k10", -1.0, lambda p, s: _if((p < 0) * (s["progress"] >= 0.1 * s["abs_step"]),
                                              s["k"], p)),
    Accumulator("k90", -1.0, lambda p, s: _if((p < 0) * (s["progress"] >= 0.9 * s["abs_step"]),
                                              s["k"], p)),
    Accumulator("k_out", -1.0, lambda p, s: _if(s["abs_e"] > s["tol"], s["k"], p)),
    Accumulator("k_exit", -1.0, lambda p, s: _if((p < 0) * s["outside"], s["k"], p)),
    Accumulator("win_e_max", -np.inf, _in_window(lambda p, s: _fmax(p, s["e"]))),
    Accumulator("win_e_min", np.inf, _in_window(lambda p, s: _fmin(p, s["e"]))),
    *(Accumulator(f"blk_max{j}", -np.inf, _block(j, _fmax)) for j in range(NBLOCKS)),
    *(Accumulator(f"blk_min{j}", np.inf, _block(j, _fmin)) for j in range(NBLOCKS)),
    Accumulator("sat_count", 0.0, _in_window(lambda p, s: p + s["saturated"])),
    # sums of u and u^2 over the window's first and last blocks: is the input at rest?
    *(Accumulator(f"u_{where}_{kind}", 0.0, _block(j, lambda p, x: p + x, signal))
      for where, j in (("first", 0), ("last", NBLOCKS - 1))
      for kind, signal in (("sum", lambda s: s["u"]), ("sq", lambda s: s["u"] * s["u"]))),
    Accumulator("rev_dir", 0.0, lambda p, s: _swing(s)[0]),
    Accumulator("rev_ext", 0.0, lambda p, s: _swing(s)[1]),
    Accumulator("reversals", 0.0, lambda p, s: p + _swing(s)[2]),
    Accumulator("swing_sum", 0.0, _on_reversal(
        lambda p, s, x: p + _if(s["prev"]["reversals"] > 0,
                                _fabs(x - s["prev"]["rev_last"]), 0))),
    Accumulator("swing_first", 0.0, _on_reversal(
        lambda p, s, x: _if(s["prev"]["reversals"] == 1, _fabs(x - s["prev"]["rev_last"]), p))),
    Accumulator("swing_last", 0.0, _on_reversal(
        lambda p, s, x: _if(s["prev"]["reversals"] > 0, _fabs(x - s["prev"]["rev_last"]), p))),
    Accumulator("rev_last", 0.0, _on_reversal(lambda p, s, x: x)),
    Accumulator("k_rev_first", -1.0, _on_reversal(lambda p, s, x: _if(p < 0, s["k"], p))),
    Accumulator("k_rev_last", -1.0, _on_reversal(lambda p, s, x: s["k"])),
    # the response to a disturbance starting at sample k_dist (inf: none), see _disturbance
    Accumulator("dist_peak", -np.inf, lambda p, s: _if(s["after_dist"], _fmax(p, s["abs_e"]), p)),
    Accumulator("k_dist_out", -1.0,
                lambda p, s: _if(s["after_dist"] * (s["abs_e"] > s["tol"]), s["k"], p)),
)

#: The accumulators whose update never reads the run's length (no tail, window or swing
#: gating): a run continued to a longer length keeps them, the others restart with the longer
#: run's window (:func:`fl_design.sim._adaptive.continue_runs`).
WHOLE_RUN = ("e_max", "e_min", "abs_e_sum", "u2_sum", "du_sum", "est2_sum", "k10", "k90",
             "k_out", "k_exit", "dist_peak", "k_dist_out")

#: Accumulators that feed a metric but not the classification, by metric: a sweep asked for
#: some metrics only (``fl.sweep(..., metrics=[...])``) updates these for the metrics asked
#: for and no others (every accumulator not listed here feeds the status and always runs).
#: Measured on the TRMS (AVX2): the kernel step without them is about 9 % faster.
METRIC_ACCUMULATORS = {
    "overshoot": ("e_max", "e_min"), "rise_time": ("k10",), "settling_time": ("k_out",),
    "iae": ("abs_e_sum",), "input_rms": ("u2_sum",), "input_tv": ("du_sum",),
    "estimation_rms": ("est2_sum",), "time_to_tolerance": ("k_out",),
    "region_exit_time": ("k_exit",), "disturbance_peak": ("dist_peak",),
    "recovery_time": ("k_dist_out",),
}
#: The accumulators of :data:`METRIC_ACCUMULATORS` (the others feed the status).
METRIC_ONLY = frozenset(name for names in METRIC_ACCUMULATORS.values() for name in names)
#: Metrics of the response to a scenario's disturbance (:mod:`fl_design.sim._disturbance`).
DISTURBANCE_METRICS = ("disturbance_peak", "recovery_time")

#: Constants of a run stored with its accumulators (inputs of the finalization).
RUN_CONSTANTS = ("N", "k_tail", "k_mid", "y0", "step", "tol", "noise", "k_dist")


def requested_metrics(metrics) -> tuple[str, ...] | None:
    """The validated metric names a caller asks for (None: every metric).

    Parameters
    ----------
    metrics : sequence of str or None
        Names from :data:`METRIC_NAMES` or :data:`DISTURBANCE_METRICS`; ``()`` asks for the
        status (and ``divergence_time``) only.

    Returns
    -------
    tuple of str or None
        Sorted names without repeats, or None.

    Raises
    ------
    ParameterError
        Not a list of names, or an unknown name (the message lists the valid ones).

    Examples
    --------
    >>> from fl_design.sim._metrics import requested_metrics
    >>> requested_metrics(["overshoot", "iae"]), requested_metrics(None)
    (('iae', 'overshoot'), None)
    """
    from ..errors import ParameterError

    if metrics is None:
        return None
    valid = (*METRIC_NAMES, *DISTURBANCE_METRICS)
    if isinstance(metrics, str) or not hasattr(metrics, "__iter__"):
        raise ParameterError(f"metrics must be a list of metric names (or None: all), got "
                             f"{metrics!r}; write [{metrics!r}] for one")
    names = list(metrics)
    bad = [m for m in names if not isinstance(m, str) or m not in valid]
    if bad:
        raise ParameterError(f"unknown metric(s) {bad} in metrics={names!r}; valid names: "
                             f"{list(valid)}")
    return tuple(sorted(set(names)))


def accumulators_for(metrics: tuple[str, ...] | None) -> tuple[str, ...] | None:
    """The accumulators the kernel must update for ``metrics`` (None: all of them).

    The status needs every accumulator outside :data:`METRIC_ONLY`; each metric adds its
    own (:data:`METRIC_ACCUMULATORS`).

    Parameters
    ----------
    metrics : tuple of str or None
        Validated names (:func:`requested_metrics`).

    Returns
    -------
    tuple of str or None
        Accumulator names in :data:`ACCUMULATORS` order, or None (all).

    Examples
    --------
    >>> from fl_design.sim._metrics import accumulators_for
    >>> kept = accumulators_for(("overshoot",))
    >>> "e_max" in kept, "iae" in kept, "est2_sum" in kept, "reversals" in kept
    (True, False, False, True)
    """
    if metrics is None:
        return None
    extra = {name for m in metrics for name in METRIC_ACCUMULATORS.get(m, ())}
    return tuple(a.name for a in ACCUMULATORS if a.name not in METRIC_ONLY or a.name in extra)


def metric_layout(rho: int) -> Layout:
    """The accumulator fields of :data:`ACCUMULATORS` for relative degree ``rho``.

    Parameters
    ----------
    rho : int
        Relative degree (``est2_sum`` has ``rho + 1`` entries).

    Returns
    -------
    Layout
        Name -> slice of every accumulator in the packed vector.

    Examples
    --------
    >>> from fl_design.sim._metrics import metric_layout
    >>> metric_layout(2)["est2_sum"]
    slice(5, 8, None)
    """
    return Layout(tuple((a.name, rho + 1 if a.per_estimate else 1) for a in ACCUMULATORS))


def initial_values(rho: int) -> dict[str, np.ndarray]:
    """Initial value of every accumulator (``{name: array}``).

    Parameters
    ----------
    rho : int
        Relative degree: the per-estimate accumulators get ``rho + 1`` entries.

    Returns
    -------
    dict
        ``{name: (1,) or (rho + 1,) array}`` of the accumulators' initial values.

    Examples
    --------
    >>> from fl_design.sim._metrics import initial_values
    >>> initial_values(1)["est2_sum"].tolist()
    [0.0, 0.0]
    """
    return {a.name: np.full(rho + 1 if a.per_estimate else 1, a.initial) for a in ACCUMULATORS}


def signals(*, e, u, u_prev, k, est_err, y, y0, step, tol, k_tail, k_mid, outside, noise=0.0,
            u_range=None, k_dist=None) -> dict:
    """The per-sample signals the accumulators read (CasADi expressions).

    Parameters
    ----------
    e, u, u_prev, k, y : casadi.SX
        Error ``y - r``, input ``u_k``, previous input, sample index, true output.
    est_err : casadi.SX
        ``(rho + 1,)`` estimation errors.
    y0, step, tol, k_tail, k_mid : casadi.SX
        Run constants (``k_mid``: first sample of the second half of the tail).
    outside : casadi.SX
        1 when the plant state is outside its declared region at sample ``k``.
    noise : casadi.SX or float, optional
        The run's noise level (:data:`RUN_CONSTANTS` ``noise``): sets the swing hysteresis.
    u_range : (float, float) or None, optional
        The controller's input saturation; ``u`` at either end counts as saturated.
    k_dist : casadi.SX or float, optional
        First sample of the scenario's disturbance (default None: none).

    Returns
    -------
    dict
        ``{name: casadi.SX}`` per-sample signals that :func:`update` accumulates.

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.sim._metrics import signals
    >>> x = ca.SX.sym("x")
    >>> sorted(signals(e=x, u=x, u_prev=x, k=x, est_err=x, y=x, y0=x, step=x, tol=x,
    ...                k_tail=x, k_mid=x, outside=x))[:3]
    ['abs_du', 'abs_e', 'abs_step']
    """
    import casadi as ca

    saturated = 0
    if u_range is not None:
        lo, hi = (float(v) for v in u_range)
        margin = 1e-9 * (hi - lo)  # the saturation returns the limit itself
        saturated = (u <= lo + margin) + (u >= hi - margin)
    return {"e": e, "abs_e": ca.fabs(e), "u": u, "abs_du": ca.fabs(u - u_prev), "k": k,
            "est_err": est_err, "tail": k >= k_tail, "tol": tol, "abs_step": ca.fabs(step),
            "progress": ca.sign(step) * (y - y0), "k_mid": k_mid, "k_tail": k_tail,
            "outside": outside, "noise": noise, "saturated": saturated,
            "after_dist": 0 if k_dist is None else k >= k_dist}


def update(acc: dict, s: dict) -> dict:
    """``{name: new value}`` of every accumulator for one sample (CasADi expressions).

    Parameters
    ----------
    acc : dict
        Previous values by name.
    s : dict
        Per-sample signals (:func:`signals`).

    Returns
    -------
    dict
        ``{name: casadi.SX}`` for every accumulator of :data:`ACCUMULATORS`.

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.sim._metrics import ACCUMULATORS, signals, update
    >>> x = ca.SX.sym("x")
    >>> sig = signals(e=x, u=x, u_prev=x, k=x, est_err=x, y=x, y0=x, step=x, tol=x, k_tail=x,
    ...               k_mid=x, outside=x)
    >>> len(update({a.name: x for a in ACCUMULATORS}, sig)) == len(ACCUMULATORS)
    True
    """
    s = {**s, "prev": acc}
    return {a.name: a.update(acc[a.name], s) for a in ACCUMULATORS}


@dataclass(frozen=True)
class Metric:
    """A metric of a run: name, unit, and how it follows from the accumulators.

    Parameters
    ----------
    name : str
        Metric name (a key of ``Response.metrics`` and ``StabilityMap.metrics``).
    unit : str
        Unit for tables and axes (``"%"``, ``"s"``, ``"output"``, ``"input"``...).
    finalize : callable
        ``finalize(g, T) -> array`` from the accumulators and run constants ``g`` (arrays,
        broadcast) and the sampling time.
    per_estimate : bool, optional
        One value per estimate (trailing axis ``rho + 1``).

    Examples
    --------
    >>> from fl_design.sim._metrics import METRICS
    >>> next(m for m in METRICS if m.name == "overshoot").unit
    '%'
    """

    name: str
    unit: str
    finalize: Callable
    per_estimate: bool = False


def _overshoot(g, T):
    astep = np.abs(g["step"])
    peak = np.where(g["step"] > 0, g["e_max"], -g["e_min"])
    return np.where(astep > 0, 100.0 * np.maximum(0.0, peak) / np.where(astep > 0, astep, 1),
                    np.nan)


def _rise(g, T):
    ok = (np.abs(g["step"]) > 0) & (g["k10"] >= 0) & (g["k90"] >= 0)
    return np.where(ok, (g["k90"] - g["k10"]) * T, np.nan)


#: The metrics of a run (order = table order in reports).
METRICS = (
    Metric("overshoot", "%", _overshoot),
    Metric("rise_time", "s", _rise),
    Metric("settling_time", "s",
           lambda g, T: np.where(g["k_out"] >= g["N"] - 1, np.nan, (g["k_out"] + 1) * T)),
    Metric("steady_state_error", "output", lambda g, T: g["tail_e_sum"] / (g["N"] - g["k_tail"])),
    Metric("iae", "output s", lambda g, T: g["abs_e_sum"] * T),
    Metric("input_rms", "input", lambda g, T: np.sqrt(g["u2_sum"] / g["N"])),
    Metric("input_tv", "input", lambda g, T: g["du_sum"]),
    Metric("estimation_rms", "per estimate",
           lambda g, T: np.sqrt(g["est2_sum"] / np.asarray(g["N"])[..., None]), per_estimate=True),
    Metric("tail_error", "output", lambda g, T: g["tail_abs_e_max"]),
    Metric("tail_amplitude", "output", lambda g, T: g["tail_e_max"] - g["tail_e_min"]),
    Metric("time_to_tolerance", "s", lambda g, T: _time_to_tolerance(g, T)),
    Metric("reversals", "count", lambda g, T: g["reversals"]),
    Metric("oscillation_period", "s", lambda g, T: g["_ev"]["period"] * T),
    Metric("oscillation_amplitude", "output", lambda g, T: g["_ev"]["amplitude"]),
    Metric("decay_rate", "1/s", lambda g, T: -g["_ev"]["rate"] / T),
    Metric("decay_rate_se", "1/s", lambda g, T: g["_ev"]["rate_se"] / T),
    Metric("envelope_change", "fraction", lambda g, T: g["_ev"]["change"]),
    Metric("noise_floor", "output", lambda g, T: g["_ev"]["floor"]),
    Metric("saturated_fraction", "fraction", lambda g, T: g["_ev"]["saturated"]),
    Metric("input_drift", "input", lambda g, T: g["_ev"]["u_drift"]),
    Metric("input_moving", "bool", lambda g, T: g["_ev"]["u_moving"].astype(float)),
    Metric("reached", "bool", lambda g, T: g["_ev"]["reached"].astype(float)),
)
METRIC_NAMES = tuple(m.name for m in METRICS) + ("divergence_time", "region_exit_time")


def _time_to_tolerance(g, T):
    """``settling_time`` when converged; for a converging run the run's end plus the time the
    tail's largest ``|e|`` needs to reach the band at the fitted decay rate
    (``ln(tail_error / band) / decay rate``)."""
    status, ev = g["_status"], g["_ev"]
    settled = np.where(g["k_out"] >= g["N"] - 1, np.nan, (g["k_out"] + 1) * T)
    more = np.log(g["tail_abs_e_max"] / ev["band"]) / -ev["rate"]
    estimate = (g["N"] + np.maximum(more, 0.0)) * T
    return np.where(status == Status.CONVERGED, settled,
                    np.where(status == Status.CONVERGING, estimate, np.nan))


def metrics_from_summary(summary: dict, T: float,
                         metrics: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """Every metric of :data:`METRICS` (or those asked for), ``divergence_time`` and ``status``.

    Parameters
    ----------
    summary : dict
        Accumulators (:data:`ACCUMULATORS`), run constants (:data:`RUN_CONSTANTS`),
        ``diverged`` and ``k_div``; arrays of any shape broadcast, ``est2_sum`` with a trailing
        axis of length ``rho + 1``.
    T : float
        Sampling time.
    metrics : tuple of str, optional
        Only these metrics (:func:`requested_metrics`; ``divergence_time`` and ``status``
        always); default None: all of them.

    Returns
    -------
    dict
        ``METRIC_NAMES`` (or ``metrics``) -> arrays, plus ``status`` (codes).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._metrics import initial_values, metrics_from_summary
    >>> s = dict(initial_values(2), N=10, k_tail=8, step=1.0, tol=0.02, diverged=0, k_div=-1,
    ...          e_max=0.1, e_min=-1.0, abs_e_sum=2.0, u2_sum=10.0, du_sum=1.0,
    ...          tail_abs_e_max=0.01, tail_e_max=0.01, tail_e_min=0.0, tail_e_sum=0.01,
    ...          k10=1, k90=3, k_out=5, k_mid=9)
    >>> m = metrics_from_summary(s, 0.1)
    >>> [round(float(m[k]), 12) for k in ("overshoot", "rise_time", "settling_time")]
    [10.0, 0.2, 0.6]
    >>> m["status"].tolist()  # within the band over the tail
    [2]
    """
    g = {k: np.asarray(v, dtype=float) for k, v in summary.items()}
    g.setdefault("noise", np.zeros_like(g["tol"]))
    div = g["diverged"] != 0
    out = {}
    g["_ev"] = evidence(g)  # once: the classification and the metrics share it
    g["_status"] = classify(g)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for metric in METRICS:
            if metrics is not None and metric.name not in metrics:
                continue
            value = metric.finalize(g, T)
            out[metric.name] = np.where(div[..., None] if metric.per_estimate else div,
                                        np.nan, value)
    out["divergence_time"] = np.where(div, g["k_div"] * T, np.nan)
    if metrics is None or "region_exit_time" in metrics:
        out["region_exit_time"] = np.where(g["k_exit"] >= 0, g["k_exit"] * T, np.nan)
    out["status"] = g["_status"]
    return out


__all__ = [
    "ACCUMULATORS",
    "DISTURBANCE_METRICS",
    "METRICS",
    "METRIC_ACCUMULATORS",
    "METRIC_NAMES",
    "METRIC_ONLY",
    "NBLOCKS",
    "NOISE_P2P",
    "RUN_CONSTANTS",
    "STATUS_CODES",
    "STATUS_NAMES",
    "WHOLE_RUN",
    "Accumulator",
    "Metric",
    "Status",
    "accumulators_for",
    "classify",
    "initial_values",
    "metric_layout",
    "metrics_from_summary",
    "requested_metrics",
    "signals",
    "update",
]
