"""How a run is classified: :class:`Status` and :func:`classify`, from the run's accumulators.

The classifier measures what it names, from the run's own signals (the accumulators of
:mod:`fl_design.sim._metrics`, so a sweep classifies every grid point the same way a single
run does); :func:`evidence` gives the measurements:

* **the band**: ``tol`` plus half the noise floor, ``NOISE_P2P * noise`` (the run's noise
  standard deviation, with quantization): ripple at the noise level is not an error, and not
  an oscillation;
* **swings** over the analysis window, the run's second half: reversals of ``e`` with a
  hysteresis of ``max(tol / 2, half the noise floor)``, their period and mean peak-to-peak,
  and the last swing against the first;
* **the envelope's decay**: ``log`` of the largest ``|e|`` over every half period (one of
  :data:`NBLOCKS` blocks when there is no swing) fitted against time by least squares over the
  whole window: the rate, its standard error (the confidence) and the fitted change;
* **time at the input limits**, the **input's drift** over the window (its mean over the last
  block minus over the first) and whether the output ever covered 90 % of the step.

The statuses, in this order:

* ``solver_failed``: the reference integrator (``cvodes``) gave up on a sample although the
  state was within bounds: a failure of the tool, not of the loop;
* ``diverged``: at some sample the plant state left ``|x - x_op| <= divergence_bound`` or a
  state or the input became non-finite (NaN, inf, finite escape); the run is stopped there;
* ``converged``: over the tail ``|e| <= band``, ``|mean e| <= tol`` and a peak-to-peak within
  ``max(tol, noise floor)``;
* ``converging``: the envelope decays, significantly (``t = rate / se < -T_SIGNIFICANT``) and
  by more than :data:`MIN_CHANGE` over the window, towards the band: a strictly decreasing
  envelope whose successive drops, fitted as a geometric sequence, add up to an offset outside
  the band is heading for that offset instead (``time_to_tolerance`` extrapolates the decay).
  A slow decay is converging too when its fit is confident at 95 % (:data:`T_CONFIDENT`),
  with the envelope measured: ``e`` on one side of the reference or swings of a known period
  (a single slow crossing dips ``|e|``: a V that depends on where the window falls in the
  swing, not an envelope); the conditions are listed in :func:`classify`;
* ``oscillating``: at least :data:`MIN_REVERSALS` reversals, swings larger than the band, not
  decaying (the envelope shrinks by less than :data:`MIN_CHANGE` and the last swing is not
  smaller than the first by more than that), at least :data:`MIN_PERIODS` full swings in the
  window, and not growing significantly: a limit cycle (how an unstable loop usually looks
  behind input saturation); a decaying swing, or one slower than the run can show twice, is
  never oscillating;
* ``stalled``: bounded, the tail's error outside the band (inside it a run is never
  stalled), no such swings, envelope flat or heading for an
  offset, and the loop at rest (the input steady: drifting over the window by at most
  :data:`U_DRIFT` of its level or by less than its noise, or pinned at a limit): not
  approaching the reference;
* ``undecided``: what remains is ambiguous in this run: an envelope that grows (a limit cycle
  or a divergence to come), a decay the fit cannot confirm at 95 % (or with ``u`` pinned at
  a limit), swings that decay too little for the fit to tell, or a flat error while the
  controller is still moving its input (a run too short to judge). A longer run decides.

The integer codes are what a :class:`fl_design.StabilityMap` stores; ``undecided`` (3) and
``stalled`` (4) were added after the others, which keep their codes: test membership with
:attr:`Status.bounded`, :attr:`Status.convergent`, :data:`BOUNDED_CODES` or
:data:`CONVERGENT_CODES`, not by order.

Examples
--------
>>> from fl_design.sim import Status
>>> [s.label for s in Status if s.bounded]
['oscillating', 'converging', 'converged', 'undecided', 'stalled']
"""

from __future__ import annotations

import enum

import numpy as np

from ._envelope import asymptote, curvature_t, fit_line


class Status(enum.IntEnum):
    """Classification of a run (integer codes are what a :class:`StabilityMap` stores).

    Examples
    --------
    >>> from fl_design.sim import Status
    >>> Status(2).label, Status.from_label("diverged").value, Status.CONVERGING.bounded
    ('converged', -1, True)
    >>> Status.UNDECIDED.bounded, Status.UNDECIDED.convergent
    (True, False)
    """

    SOLVER_FAILED = -2
    DIVERGED = -1
    OSCILLATING = 0
    CONVERGING = 1
    CONVERGED = 2
    UNDECIDED = 3
    STALLED = 4

    @property
    def bounded(self) -> bool:
        """The run stayed within bounds (oscillating, converging, converged, undecided,
        stalled)."""
        return int(self) in BOUNDED_CODES

    @property
    def convergent(self) -> bool:
        """The error converges (converging or converged): Theorem 1's conclusion observed."""
        return int(self) in CONVERGENT_CODES

    @property
    def label(self) -> str:
        """Lower-case name, e.g. ``"converged"``."""
        return self.name.lower()

    @classmethod
    def from_label(cls, label: str) -> Status:
        """The status named ``label`` (``"converged"``, ``"oscillating"``, ...).

        Parameters
        ----------
        label : str
            A lower-case status name.

        Returns
        -------
        Status
            The member of that name.

        Examples
        --------
        >>> from fl_design.sim import Status
        >>> Status.from_label("undecided")
        <Status.UNDECIDED: 3>
        """
        return cls[label.upper()]


#: Codes of the runs that stayed within bounds.
BOUNDED_CODES = (0, 1, 2, 3, 4)
#: Codes of the runs whose error converges (converging, converged).
CONVERGENT_CODES = (1, 2)
#: Integer codes of the classification by label (``StabilityMap.status`` holds these).
STATUS_CODES = {s.label: int(s) for s in Status}
STATUS_NAMES = {code: name for name, code in STATUS_CODES.items()}

#: Blocks of the analysis window (the run's second half) whose extremes the kernel keeps.
NBLOCKS = 8
#: Peak-to-peak of noise-level ripple, in noise standard deviations (a Gaussian's extremes
#: over a few thousand samples lie near +-4 std): swings and offsets below it are noise.
NOISE_P2P = 8.0
#: Hysteresis of the window's reversal count, as a fraction of the tolerance ``tol``.
REVERSAL_HYSTERESIS = 0.5
#: Reversals (one full swing) that, with an amplitude above the band, make a run oscillate.
MIN_REVERSALS = 2
#: |t| of the envelope's fitted log-slope beyond which the trend counts (about 99.9 % with
#: the fit's few degrees of freedom).
T_SIGNIFICANT = 4.0
#: Relative change of the fitted envelope over the window below which it is flat.
MIN_CHANGE = 0.05
#: Full swings the analysis window must hold for a sustained swing to be called oscillating
#: (a swing slower than that, decaying or not, cannot be judged in the run: undecided).
MIN_PERIODS = 1
#: One-sided 95 % Student quantiles ``scipy.stats.t.ppf(0.95, dof)``, indexed by the envelope
#: fit's degrees of freedom (at most ``NBLOCKS - 2``; NaN for none): a slow decay's confidence.
T_CONFIDENT = (np.nan, 6.3138, 2.9200, 2.3534, 2.1318, 2.0150, 1.9432)
#: Relative change of the input's mean over the window (first block to last) above which the
#: controller is still moving it: the loop has not come to rest, so a flat error is not a
#: stall yet (a run too short to judge).
U_DRIFT = 0.1


def window_geometry(summary: dict):
    """``(start, length)`` of the analysis window and of its blocks, in samples.

    The window is the run's second half, from ``floor(N' / 2)`` with ``N' = 2 k_mid - k_tail``
    (the kernel's reconstruction of ``N``), cut into :data:`NBLOCKS` blocks of ``length``.

    Parameters
    ----------
    summary : dict
        ``k_tail`` and ``k_mid`` (arrays broadcast).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)

    Examples
    --------
    >>> from fl_design.sim._status import window_geometry
    >>> [float(v) for v in window_geometry({"k_tail": 800, "k_mid": 900})]
    [500.0, 62.5]
    """
    n = 2 * np.asarray(summary["k_mid"], dtype=float) - np.asarray(summary["k_tail"], dtype=float)
    start = np.floor(n / 2)
    return start, (n - start) / NBLOCKS


def evidence(summary: dict) -> dict:
    """What the run's accumulators show, in samples: the measurements behind its status.

    * ``band``: the converged band, ``tol`` plus half the noise floor
      ``NOISE_P2P * noise`` (ripple at the noise level is not an error);
    * ``reversals``, ``period`` and ``amplitude`` (mean peak-to-peak) of the swings in the
      analysis window (the run's second half);
    * ``rate`` and ``rate_se``: the fitted log-slope of the error's envelope (per sample) and
      its standard error, over the whole window: the largest ``|e|`` over every half period
      (one block when there is no swing) against time; ``change``: the fitted relative change
      of the envelope over the window; ``level``: the fitted envelope at the window's end;
      ``asymptote``: where a strictly decreasing envelope is heading, its successive drops
      fitted as a geometric sequence (NaN otherwise; about 0 for a decay to the reference);
      ``curvature_t``: the ``t`` of a quadratic term in ``log`` envelope (a hump: half of a
      swing slower than the window); ``spread``: largest minus smallest block ``|e|``, ``top``
      the largest;
    * ``u_drift``: mean ``u`` over the window's last block minus over its first;
      ``u_moving``: that drift exceeds :data:`U_DRIFT` of the input's level and the spread of
      ``u`` within those two blocks (root sum of their variances: noise is no drift), and
      ``u`` is not saturated over half of the window (the loop has not come to rest);
    * ``saturated``: fraction of the window with ``u`` at a limit; ``reached``: the output
      covered 90 % of the step at some time.

    Parameters
    ----------
    summary : dict
        Accumulators (:data:`fl_design.sim._metrics.ACCUMULATORS`) and run constants.

    Returns
    -------
    dict of numpy.ndarray

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._status import NBLOCKS, evidence
    >>> env = 0.1 * np.exp(-np.arange(NBLOCKS) / 4)  # |e| decays by e every 4 blocks (250 k)
    >>> s = {"k_tail": 800, "k_mid": 900, "tol": 0.001, "noise": 0.0, "reversals": 0,
    ...      "swing_sum": 0, "k_rev_first": -1, "k_rev_last": -1, "sat_count": 0, "k90": 10,
    ...      **{f"blk_max{j}": env[j] for j in range(NBLOCKS)},
    ...      **{f"blk_min{j}": 0.0 for j in range(NBLOCKS)}}
    >>> round(-1 / float(evidence(s)["rate"]), 6)  # time constant in samples
    250.0
    """
    with np.errstate(all="ignore"):  # a diverged run's empty blocks give NaN, silently
        return _evidence(summary)


def _evidence(summary: dict) -> dict:
    """:func:`evidence` without the error-state guard."""
    g = {k: np.asarray(v, dtype=float) for k, v in summary.items() if k != "est2_sum"}
    start, length = window_geometry(g)
    tol = g["tol"]
    noise = g.get("noise", np.zeros_like(tol))
    floor = NOISE_P2P * noise
    rev = g["reversals"]
    with np.errstate(divide="ignore", invalid="ignore"):
        period = np.where(rev >= 2, 2 * (g["k_rev_last"] - g["k_rev_first"]) / (rev - 1), np.nan)
        amplitude = np.where(rev >= 2, g["swing_sum"] / (rev - 1), np.nan)
        swing_ratio = np.where(rev >= 3, g.get("swing_last", np.nan) / g.get("swing_first", np.nan),
                               np.nan)
    hi = np.stack([g[f"blk_max{j}"] for j in range(NBLOCKS)], -1)
    lo = np.stack([g[f"blk_min{j}"] for j in range(NBLOCKS)], -1)
    block = np.where(np.isfinite(hi) & np.isfinite(lo), np.maximum(np.abs(hi), np.abs(lo)),
                     np.nan)
    # envelope: the largest |e| over a half period (at least one block)
    width = np.clip(np.ceil(np.nan_to_num(period / 2 / length, nan=1.0)), 1, NBLOCKS - 2)
    shape = np.broadcast_shapes(np.shape(width), block.shape[:-1])
    width = np.broadcast_to(width, shape)
    block = np.broadcast_to(block, (*shape, NBLOCKS))
    slope = np.full(shape, np.nan)
    se, level, npts, heading = slope.copy(), slope.copy(), np.zeros(shape), slope.copy()
    curved = slope.copy()
    lengths = np.broadcast_to(length, shape)
    for w in range(1, NBLOCKS - 1):
        pick = width == w
        if not np.any(pick):
            continue
        # the fits of the runs of this width only (each run's own row: the same bits)
        m = NBLOCKS - w + 1
        blk = block[pick]
        env = np.stack([np.max(blk[..., i:i + w], axis=-1) for i in range(m)], -1)
        centres = (np.arange(m) + w / 2) * lengths[pick][..., None]
        fit = (*fit_line(env, centres), asymptote(env), curvature_t(env, centres))
        for out, value in zip((slope, se, level, npts, heading, curved), fit):
            out[pick] = value
    span = np.broadcast_to(length, shape) * (NBLOCKS - width)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        change = np.expm1(slope * span)
        n_window = NBLOCKS * length
        saturated = g.get("sat_count", np.zeros_like(tol)) / n_window
        # mean input over the window's first and last blocks (NaN without the accumulators);
        # block j holds the samples kw + j L <= k < kw + (j + 1) L
        n_first = np.ceil(start + length) - np.ceil(start)
        n_last = np.ceil(start + NBLOCKS * length) - np.ceil(start + (NBLOCKS - 1) * length)
        u_first = g.get("u_first_sum", np.nan) / n_first
        u_last = g.get("u_last_sum", np.nan) / n_last
        u_drift = u_last - u_first
        # the spread of u within those blocks (noise, or the ramp itself: a steady ramp's
        # within-block spread is 1/(7 sqrt 12) of its drift over the window)
        spread = np.sqrt(np.maximum(g.get("u_first_sq", np.nan) / n_first - u_first ** 2, 0.0)
                         + np.maximum(g.get("u_last_sq", np.nan) / n_last - u_last ** 2, 0.0))
        u_moving = ((np.abs(u_drift) > U_DRIFT * np.maximum(np.abs(u_first), np.abs(u_last)))
                    & (np.abs(u_drift) > spread))
    return {"band": tol + floor / 2, "floor": floor, "reversals": rev, "period": period,
            "amplitude": amplitude, "swing_ratio": swing_ratio, "rate": slope, "rate_se": se, "change": change,
            "level": level, "asymptote": heading, "curvature_t": curved, "fit_points": npts,
            "spread": np.fmax.reduce(block, -1) - np.fmin.reduce(block, -1),
            "top": np.fmax.reduce(block, -1),
            "saturated": saturated, "u_drift": u_drift, "u_moving": u_moving & (saturated < 0.5),
            "reached": g.get("k90", np.zeros_like(tol)) >= 0, "window": n_window}


def classify(summary: dict) -> np.ndarray:
    """Status codes (:class:`Status`) from the accumulators (arrays broadcast).

    The rules, in order (the measurements are those of :func:`evidence`):

    * ``solver_failed`` / ``diverged``: as flagged by the run;
    * ``converged``: over the tail ``|e| <= band``, ``|mean e| <= tol`` and a peak-to-peak
      within the larger of ``tol`` and the noise floor;
    * ``converging``: the envelope's fitted decay is significant (``t < -T_SIGNIFICANT``) and
      more than :data:`MIN_CHANGE` over the window, and not heading for an offset outside
      the band (``asymptote``); or, a slow decay, confident at 95 % (``t <
      -T_CONFIDENT[fit_points - 2]``) and more than :data:`MIN_CHANGE`, heading for no offset,
      without sustained swings (below), with ``u`` saturated over less than half of the
      window, on one side of the reference over the window or with at least
      :data:`MIN_REVERSALS` reversals, and no hump (below);
    * ``oscillating``: at least :data:`MIN_REVERSALS` reversals of a swing whose mean
      peak-to-peak exceeds the band (``tol`` and the noise floor), and sustained: the fitted
      envelope shrinks by less than :data:`MIN_CHANGE` over the window, and the last swing
      (when measured) is at least ``1 - MIN_CHANGE`` times the first, the window holds at
      least :data:`MIN_PERIODS` periods, and it does not grow significantly (growing swings
      end in a limit cycle or a divergence: undecided);
    * ``stalled``: bounded, the tail's largest ``|e|`` outside the band, no such swings, on
      one side of the reference
      over the window (``e`` does not cross the band), and the envelope flat (no
      significant trend nor hump: a hump has ``|curvature_t| > T_SIGNIFICANT`` and a ``spread``
      above both the noise floor and ``MIN_CHANGE`` of the largest ``|e|``) or heading for an
      offset outside the band, and the input at rest (not drifting by more than
      :data:`U_DRIFT` of its level over the window, or saturated over half of it): not
      approaching the reference;
    * ``undecided``: anything else, a trend the run cannot call: a growing envelope (with or
      without swings), a decay below 95 % confidence or with ``u`` pinned, swings decaying
      too little for the fit to be sure, or a flat error while the input still moves (too
      short to judge; a longer run decides).

    Parameters
    ----------
    summary : dict
        Accumulators (:data:`fl_design.sim._metrics.ACCUMULATORS`) and run constants (``tol``,
        ``k_tail``, ``k_mid``, optionally ``noise``), ``diverged``; optionally
        ``solver_failed``.

    Returns
    -------
    numpy.ndarray of int

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._status import classify
    >>> from fl_design.sim._status import NBLOCKS
    >>> def run(hi, lo, **kw):
    ...     s = {"diverged": 0, "tol": 0.01, "k_tail": 800, "k_mid": 900, "reversals": 0,
    ...          "swing_sum": 0, "k_rev_first": -1, "k_rev_last": -1,
    ...          "tail_abs_e_max": max(abs(hi[-1]), abs(lo[-1])), "tail_e_max": hi[-1],
    ...          "tail_e_min": lo[-1], "tail_e_sum": 100 * (hi[-1] + lo[-1]) / 2,
    ...          "win_e_max": max(hi), "win_e_min": min(lo)}
    ...     s |= {f"blk_max{j}": hi[j] for j in range(NBLOCKS)}
    ...     s |= {f"blk_min{j}": lo[j] for j in range(NBLOCKS)}
    ...     return int(classify(s | kw))
    >>> flat = [0.2] * NBLOCKS
    >>> run(flat, [0.19] * NBLOCKS)  # sits at an offset: stalled
    4
    >>> run(list(0.2 * np.exp(-np.arange(NBLOCKS) / 3)), [0.0] * NBLOCKS)  # decays: converging
    1
    >>> run(flat, [-0.2] * NBLOCKS, reversals=6, swing_sum=2.0, k_rev_first=520,
    ...     k_rev_last=960)  # sustained swings of 0.4: oscillating
    0
    """
    with np.errstate(all="ignore"):
        return _classify(summary)


def _classify(summary: dict) -> np.ndarray:
    div = np.asarray(summary["diverged"]) != 0
    failed = np.asarray(summary.get("solver_failed", 0)) != 0
    ev = summary["_ev"] if "_ev" in summary else evidence(summary)  # computed once per table
    tol, band = np.asarray(summary["tol"], dtype=float), ev["band"]
    n_tail = 2 * (np.asarray(summary["k_mid"], float) - np.asarray(summary["k_tail"], float))
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.asarray(summary.get("tail_e_sum", 0.0)) / np.maximum(n_tail, 1)
        p2p = np.asarray(summary["tail_e_max"]) - np.asarray(summary["tail_e_min"])
        converged = ((np.asarray(summary["tail_abs_e_max"]) <= band) & (np.abs(mean) <= tol)
                     & (p2p <= np.maximum(tol, ev["floor"])))
        # a stall is an error outside the band: inside it, whatever else, never stalled
        outside = np.asarray(summary["tail_abs_e_max"]) > band
        t = ev["rate"] / ev["rate_se"]
        t = np.where(ev["rate_se"] == 0, np.sign(ev["rate"]) * np.inf, t)
        swinging = (ev["reversals"] >= MIN_REVERSALS) & (ev["amplitude"] > np.maximum(tol, ev["floor"]))
        # a monotone decay towards an offset outside the band (swings: their envelope decides)
        offset = (ev["asymptote"] > band) & ~swinging
        decaying = (t < -T_SIGNIFICANT) & (ev["change"] < -MIN_CHANGE) & ~offset
        # a stall sits on one side of the reference: an error crossing it is moving
        one_sided = ((np.asarray(summary.get("win_e_min", -np.inf)) > -band)
                     | (np.asarray(summary.get("win_e_max", np.inf)) < band))
        # a hump counts when significant and larger than MIN_CHANGE of |e| and the noise floor
        hump = ((np.abs(ev["curvature_t"]) > T_SIGNIFICANT)
                & (ev["spread"] > np.maximum(MIN_CHANGE * ev["top"], ev["floor"])))
        flat = ((np.abs(t) < 1) | (np.abs(ev["change"]) < MIN_CHANGE) | (ev["rate"] == 0)) \
            & ~hump
        growing = (t > T_SIGNIFICANT) & (ev["change"] > MIN_CHANGE)
        # sustained: over at least MIN_PERIODS full swings in the window, not a confident decay
        # (a decaying swing, or one slower than the window, is no oscillation: converging or
        # undecided)
        ratio = ev["swing_ratio"]
        seen = ev["period"] * MIN_PERIODS <= ev["window"]
        # a slow decay (rules in the docstring); no hump: the fit's line describes the envelope
        dof = np.clip(np.nan_to_num(ev["fit_points"]) - 2, 0, len(T_CONFIDENT) - 1).astype(int)
        confident = t < -np.take(np.asarray(T_CONFIDENT), dof)
        # (the envelope flat OR the last swing as large as the first: a limit cycle's swings
        # vary by a few per cent from one to the next, e.g. the TRMS's stick-slip cycles)
        # (a decay is "confident" only when it is also larger than MIN_CHANGE over the window:
        # over thousands of swings a -0.3 % drift of a limit cycle is significant but no decay)
        sustained = (((ev["change"] >= -MIN_CHANGE) | (ratio >= 1 - MIN_CHANGE)) & seen
                     & ~growing & ~(confident & (ev["change"] < -MIN_CHANGE)))
        slow_decay = (confident & (ev["change"] < -MIN_CHANGE) & ~offset
                      & ~(swinging & sustained) & (ev["saturated"] < 0.5)
                      & (one_sided | (ev["reversals"] >= MIN_REVERSALS)) & ~hump)
        # a window shorter than the designed loop's time constant (simulate gives it; sweeps
        # do not) cannot show a stall: the loop has not had the time to act
        short = ev["window"] < np.asarray(summary.get("loop_tau_samples", 0.0), dtype=float)
    code = np.select(
        [div, converged, decaying, swinging & sustained, slow_decay,
         ~swinging & (flat | offset) & one_sided & ~ev["u_moving"] & outside & ~short],
        [int(Status.DIVERGED), int(Status.CONVERGED), int(Status.CONVERGING),
         int(Status.OSCILLATING), int(Status.CONVERGING), int(Status.STALLED)],
        int(Status.UNDECIDED))
    return np.where(failed, int(Status.SOLVER_FAILED), code).astype(int)


__all__ = [
    "BOUNDED_CODES",
    "CONVERGENT_CODES",
    "MIN_CHANGE",
    "MIN_PERIODS",
    "MIN_REVERSALS",
    "NBLOCKS",
    "NOISE_P2P",
    "REVERSAL_HYSTERESIS",
    "STATUS_CODES",
    "STATUS_NAMES",
    "T_CONFIDENT",
    "T_SIGNIFICANT",
    "U_DRIFT",
    "Status",
    "classify",
    "evidence",
    "window_geometry",
]
