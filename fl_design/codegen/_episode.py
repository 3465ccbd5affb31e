"""A saturation episode in the loop: ``u`` pinned at its limit, released, and the recovery.

:func:`saturation_episode` blocks the actuator for ``pinned`` seconds (an input disturbance
``-u_max`` at the plant: with ``u`` at ``u_max`` the plant sees nothing, so the loop pushes
``u`` to the limit and holds it there while the error persists, the integrator and the
observer's ``sigmahat`` exposed to wind-up), then releases it, and measures in the compiled C
loop (:func:`~fl_design.codegen.software_in_the_loop`, which also checks the C against
``Design.step``) and in :func:`fl_design.simulate` alike, on the same noise-free scenario:

- how long ``u`` sat at a limit within the blocked window;
- the recovery: seconds from the release until ``|y - r|`` stays within the run's tolerance
  band for good (``inf``: not within the run).

The episode passes when, in C and in Python, ``u`` was pinned for at least 90 % of the window
and the loop is back in the band within ``within`` seconds of the release (and the C matches
``Design.step``). The issue's TRMS figure is ``pinned = 10``, ``within = 3``.

Examples
--------
>>> from fl_design.codegen._episode import blocked_input
>>> blocked_input(0.5, 6, at=1.0, pinned=1.0, u_max=2.5).tolist()
[0.0, 0.0, -2.5, -2.5, 0.0, 0.0]
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError


def blocked_input(T: float, N: int, *, at: float, pinned: float, u_max: float) -> np.ndarray:
    """The input disturbance of the episode: ``-u_max`` on ``[at, at + pinned)``, else 0.

    Parameters
    ----------
    T : float
        Sampling time.
    N : int
        Samples.
    at, pinned : float
        Start and length of the blocked window (s).
    u_max : float
        The upper input limit.

    Returns
    -------
    numpy.ndarray

    Examples
    --------
    >>> from fl_design.codegen._episode import blocked_input
    >>> float(blocked_input(1e-3, 10, at=0.0, pinned=1.0, u_max=1.0).sum())
    -10.0
    """
    t = np.arange(int(N)) * float(T)
    return np.where((t >= at - 1e-12) & (t < at + pinned - 1e-12), -float(u_max), 0.0)


def _recovery(t, y, r, release: float, tol: float) -> float:
    e = np.abs(np.asarray(y, dtype=float) - np.asarray(r, dtype=float))[t >= release - 1e-12]
    if e.size == 0 or not np.all(np.isfinite(e)):
        return math.inf
    outside = np.flatnonzero(e > tol)
    if outside.size == 0:
        return 0.0
    if outside[-1] == e.size - 1:
        return math.inf
    return float((outside[-1] + 1) * (t[1] - t[0]))


def _pinned_time(t, u, window, u_lo: float, u_hi: float) -> float:
    u = np.asarray(u, dtype=float)[window]
    at_limit = np.isclose(u, u_hi, rtol=1e-6, atol=0) | np.isclose(u, u_lo, rtol=1e-6, atol=0)
    return float(np.count_nonzero(at_limit) * (t[1] - t[0]))


@dataclass(frozen=True)
class SaturationEpisode:
    """The episode's figures in C and in Python (see the module docstring).

    Parameters
    ----------
    pinned, within : float
        The blocked window's length and the recovery asked for (s).
    pinned_c, pinned_py : float
        Seconds ``u`` sat at a limit within the window (C, Python).
    recovery_c, recovery_py : float
        Seconds from the release until ``|y - r| <= tol`` for good (``inf``: not in the run).
    tol : float
        The band.
    c_matches : bool
        The C computed ``Design.step`` within the precision's bound over the run.

    Attributes
    ----------
    passed : bool
        Pinned at least 90 % of the window and back within ``within`` in both, and the C
        matches.

    Examples
    --------
    >>> from fl_design.codegen._episode import SaturationEpisode
    >>> e = SaturationEpisode(10.0, 3.0, 9.5, 9.5, 2.0, 2.1, 0.02, True)
    >>> e.passed, SaturationEpisode(10.0, 3.0, 9.5, 9.5, 2.0, 4.0, 0.02, True).passed
    (True, False)
    """

    pinned: float
    within: float
    pinned_c: float
    pinned_py: float
    recovery_c: float
    recovery_py: float
    tol: float
    c_matches: bool

    @property
    def passed(self) -> bool:
        """Pinned and recovered in C and in Python alike, and the C is the design."""
        held = min(self.pinned_c, self.pinned_py) >= 0.9 * self.pinned
        back = max(self.recovery_c, self.recovery_py) <= self.within
        return bool(held and back and self.c_matches)

    def to_dict(self) -> dict:
        """Strict-JSON fields (``inf`` recovery as None).

        Examples
        --------
        >>> from fl_design.codegen._episode import SaturationEpisode
        >>> SaturationEpisode(10.0, 3.0, 9.5, 9.5, 2.0, float("inf"), 0.02, True).to_dict()[
        ...     "recovery_py"] is None
        True
        """
        fin = lambda v: float(v) if math.isfinite(v) else None
        return {"pinned": self.pinned, "within": self.within, "pinned_c": self.pinned_c,
                "pinned_py": self.pinned_py, "recovery_c": fin(self.recovery_c),
                "recovery_py": fin(self.recovery_py), "tol": self.tol,
                "c_matches": bool(self.c_matches), "passed": self.passed}


def saturation_episode(pkg, plant, reference: float, *, x0=None, at: float = 2.0,
                       pinned: float = 10.0, within: float = 3.0,
                       after: float | None = None) -> SaturationEpisode:
    """Block the actuator for ``pinned`` s, release it, and measure the recovery (C and Python).

    Parameters
    ----------
    pkg : CPackage
        A double or float package of a design with input limits.
    plant : Plant
        The plant.
    reference : float
        Constant reference.
    x0 : array_like, optional
        Initial plant state (default: the scenario's, the operating point).
    at : float, optional
        When the actuator is blocked (s).
    pinned : float, optional
        How long (s).
    within : float, optional
        The recovery asked for (s from the release).
    after : float, optional
        Seconds simulated after the release (default ``max(2 within, 5)``).

    Returns
    -------
    SaturationEpisode

    Raises
    ------
    ParameterError
        The design has no input limits, or a time is not positive.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> from fl_design.codegen._episode import saturation_episode
    >>> pkg = generate_c(presets.paper_design(gamma=0.03), "episode_doc")
    >>> e = saturation_episode(pkg, fl.plants.trms_yaw(), 0.3, x0=[0.3, 0.0], pinned=2.0)
    >>> e.pinned_c == e.pinned_py, e.recovery_c == e.recovery_py
    (True, True)
    """
    from ..sim import Disturbance, Scenario, simulate
    from ._sil import software_in_the_loop

    design = pkg.design
    if design.controller.u_range is None:
        raise ParameterError("a saturation episode needs a design with u_limits (the limit "
                             "u is pinned at)")
    for name, v in (("at", at), ("pinned", pinned), ("within", within)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ParameterError(f"{name}={v!r} must be a positive number of seconds")
    u_lo, u_hi = (float(v) for v in design.controller.u_range)
    duration = at + pinned + (max(2.0 * within, 5.0) if after is None else float(after))
    T, n = design.T, round(duration / design.T)
    d_in = blocked_input(T, n, at=at, pinned=pinned, u_max=u_hi)
    kwargs = {} if x0 is None else {"x0": x0}
    scenario = Scenario(float(reference), n * T, disturbance=Disturbance(input=d_in), **kwargs)
    sil = software_in_the_loop(pkg, plant, scenario)
    sim = simulate(plant, design, scenario)
    t = np.arange(n) * T
    window = (t >= at - 1e-12) & (t < at + pinned - 1e-12)
    release = at + pinned
    r = np.full(n, float(reference))
    return SaturationEpisode(
        float(pinned), float(within),
        _pinned_time(t, sil.u_c, window, u_lo, u_hi), _pinned_time(t, sim.u, window, u_lo, u_hi),
        _recovery(t, sil.ym, r, release, sim.tol), _recovery(t, sim.y, r, release, sim.tol),
        float(sim.tol), bool(sil.matches))


__all__ = ["SaturationEpisode", "blocked_input", "saturation_episode"]
