"""How a run is classified: :class:`Status` and :func:`classify`, from the run's accumulators.

The statuses answer the questions of Theorem 1 (bounded? converging?) from the run, in this
order:

* ``solver_failed``: the reference integrator (``cvodes``) gave up on a sample although the
  state was within bounds: a failure of the tool, not of the loop;
* ``diverged``: at some sample the plant state left ``|x - x_op| <= divergence_bound`` or a
  state or the input became non-finite (NaN, inf, finite escape); the run is stopped there;
* ``converged``: ``tail_error <= tol`` and ``tail_amplitude <= tol``;
* ``converging``: bounded, not yet within tolerance, and the error envelope shrinks: the
  largest ``|e|`` over the second half of the tail is below :data:`SHRINK` times that over
  the first half (``time_to_tolerance`` estimates when it gets there);
* ``oscillating``: bounded, the envelope does not shrink, and the error swings: at least
  :data:`MIN_REVERSALS` direction reversals in the tail (``tail_reversals``, one full swing):
  a sustained oscillation or limit cycle (how an unstable loop usually looks behind input
  saturation);
* ``undecided``: bounded, not within tolerance, neither shrinking nor swinging (fewer than
  :data:`MIN_REVERSALS` reversals): the error creeps or sits still, and the run is too short to
  tell a mode slower than the run from a persistent offset. A longer run decides.

A reversal counts only when ``e`` moves back by more than :data:`REVERSAL_HYSTERESIS` ``* tol``
from its running extremum in the tail (the accumulators ``rev_dir``, ``rev_ext``,
``tail_reversals`` of :mod:`fl_design.sim._metrics`). Half the tolerance: a wiggle smaller than
that cannot on its own take a run out of the band (``converged`` allows a peak-to-peak of
``tol``), while the loop's response to measurement noise and the numerical jitter of a creeping
error (orders of magnitude smaller) do not count as swings; any oscillation that keeps a run
from converging with zero mean has a peak-to-peak above ``tol`` and is counted.

The integer codes are what a :class:`fl_design.StabilityMap` stores; ``undecided`` (3) was
added after the others, which keep their codes: test membership with :attr:`Status.bounded`,
:attr:`Status.convergent`, :data:`BOUNDED_CODES` or :data:`CONVERGENT_CODES`, not by order.

Examples
--------
>>> from fl_design.sim import Status
>>> [s.label for s in Status if s.bounded]
['oscillating', 'converging', 'converged', 'undecided']
"""

from __future__ import annotations

import enum

import numpy as np


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

    @property
    def bounded(self) -> bool:
        """The run stayed within bounds (oscillating, converging, converged or undecided)."""
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

        Examples
        --------
        >>> from fl_design.sim import Status
        >>> Status.from_label("undecided")
        <Status.UNDECIDED: 3>
        """
        return cls[label.upper()]


#: Codes of the runs that stayed within bounds.
BOUNDED_CODES = (0, 1, 2, 3)
#: Codes of the runs whose error converges (converging, converged).
CONVERGENT_CODES = (1, 2)
#: Integer codes of the classification by label (``StabilityMap.status`` holds these).
STATUS_CODES = {s.label: int(s) for s in Status}
STATUS_NAMES = {code: name for name, code in STATUS_CODES.items()}

#: Envelope ratio (second half of the tail / first half) below which a run is converging.
SHRINK = 0.95
#: Hysteresis of the tail's reversal count, as a fraction of the tolerance ``tol``.
REVERSAL_HYSTERESIS = 0.5
#: Reversals in the tail (one full swing) that make a non-shrinking run ``oscillating``.
MIN_REVERSALS = 2


def classify(summary: dict) -> np.ndarray:
    """Status codes (:class:`Status`) from the accumulators (arrays broadcast).

    Parameters
    ----------
    summary : dict
        At least ``diverged``, ``tail_abs_e_max``, ``tail_e_max``, ``tail_e_min``, ``tol``,
        ``env1_max``, ``env2_max``, ``tail_reversals``; optionally ``solver_failed``.

    Returns
    -------
    numpy.ndarray of int

    Examples
    --------
    >>> from fl_design.sim._status import classify
    >>> base = dict(diverged=0, tol=0.01, tail_reversals=0)
    >>> classify(dict(base, tail_abs_e_max=0.001, tail_e_max=0.001, tail_e_min=0.0,
    ...               env1_max=0.001, env2_max=0.0005)).tolist()
    2
    >>> swing = dict(base, tail_abs_e_max=0.1, tail_e_max=0.1, tail_e_min=-0.1, env1_max=0.1,
    ...              env2_max=0.1)
    >>> classify(dict(swing, tail_reversals=6)).tolist()  # sustained oscillation
    0
    >>> classify(swing).tolist()  # no reversal: a creep or an offset (undecided)
    3
    """
    div = np.asarray(summary["diverged"]) != 0
    failed = np.asarray(summary.get("solver_failed", 0)) != 0
    tol = np.asarray(summary["tol"])
    with np.errstate(invalid="ignore"):
        converged = (np.asarray(summary["tail_abs_e_max"]) <= tol) & (
            np.asarray(summary["tail_e_max"]) - np.asarray(summary["tail_e_min"]) <= tol)
        shrinking = np.asarray(summary["env2_max"]) < SHRINK * np.asarray(summary["env1_max"])
        swinging = np.asarray(summary["tail_reversals"]) >= MIN_REVERSALS
    bounded = np.where(swinging, int(Status.OSCILLATING), int(Status.UNDECIDED))
    code = np.where(div, int(Status.DIVERGED),
                    np.where(converged, int(Status.CONVERGED),
                             np.where(shrinking, int(Status.CONVERGING), bounded)))
    return np.where(failed, int(Status.SOLVER_FAILED), code).astype(int)


__all__ = ["BOUNDED_CODES", "CONVERGENT_CODES", "MIN_REVERSALS", "REVERSAL_HYSTERESIS",
           "SHRINK", "STATUS_CODES", "STATUS_NAMES", "Status", "classify"]
