"""The result of :func:`fl_design.tune`: a proposed design, its certificates and the reasons.

Examples
--------
>>> from fl_design.tuning._tuning import Tuning
>>> [f for f in ("design", "eps_certificate", "noise_gain", "reasons") if f in
...  Tuning.__dataclass_fields__]
['design', 'eps_certificate', 'noise_gain', 'reasons']
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from .._json import jsonable


@dataclass(frozen=True, repr=False)
class Tuning:
    """A design proposed by :func:`fl_design.tune`, with what backs it.

    Parameters
    ----------
    design : Design
        The proposed design (EHGO + dynamic controller).
    objective : str
        ``"least-noise"``, ``"fastest"`` or ``"overshoot <= X %"``.
    reference : float
        The step target of the check simulation and sweep (absolute, the plant's units).
    time_scale : float
        The loop's decay rate (rad/s) the gains were synthesized for.
    gains : GainSynthesis
        The gains with their decay certificate (:func:`fl_design.synthesize_gains`).
    gamma_certificate : GammaCertificate
        The admissible gamma interval at the design's eps, and its LMI certificate.
    eps_certificate : EpsCertificate
        The design's eps certified (or why not), varying ``b``.
    eps_star_certified : float or None
        The certified eps* found at the design's gamma (None: not searched: ``fl.tune``
        certifies the eps it proposes, one LMI per eps tried, and bisects no eps*).
    eps_star_linearized : float or None
        The linearized loop's eps* of the real plant (None: stable on the whole scan).
    overshoot, settling_time : float
        Predicted by the check simulation of the nonlinear plant (%, s; NaN/inf when never).
    status : str
        The check simulation's status (``"converged"`` or ``"converging"``).
    noise_gain : float
        Steady-state rms of ``u`` per unit rms of white measurement noise
        (:func:`fl_design.analysis.noise_gain`).
    sweep_converged : tuple of (float, float, str)
        The short sweep around the design: ``(eps, gamma, status)`` per run.
    ranges : dict
        ``sweep_eps``, ``sweep_gamma``, ``certify_eps``, ``certify_gamma`` ([lo, hi] lists):
        sweep and certificate ranges from ``T``, the time scale and the gamma interval.
    baseline : dict or None
        A design compared (the paper's, for the paper's TRMS): its ``name``, ``noise_gain``,
        ``overshoot``, ``status``, and ``noise_saved`` (its noise gain over ours).
    reasons : tuple of str
        One sentence per choice, with its numbers.
    tried : tuple of str
        Candidates rejected on the way, and why.
    response : Response
        The check simulation (``.plot()`` shows it).
    objective_met : bool
        The final design's check meets the objective (else ``warnings`` says by how much not).
    phase_margin : float
        Degrees at the plant input, the worst of ``b_min`` and ``b_max``
        (:func:`fl_design.analysis.loop_margins`); NaN when not computed.
    plant_time_scale : float
        The plant's time scale ``d`` (rad/s) that sizes T, the loops and the settling bound.
    warnings : tuple of str
        What an engineer should look at: an objective missed, a phase margin below 30 deg, a
        settling time beyond the stated multiple of ``1/d`` (empty: none).

    Examples
    --------
    >>> import fl_design as fl
    >>> tuned = fl.tune(fl.plants.pendulum(), reference=0.1, decays=[1])
    >>> tuned.eps_certificate.certified, tuned.status
    (True, 'converged')
    """

    design: Any
    objective: str
    reference: float
    time_scale: float
    gains: Any
    gamma_certificate: Any
    eps_certificate: Any
    eps_star_certified: float | None
    eps_star_linearized: float | None
    overshoot: float
    settling_time: float
    status: str
    noise_gain: float
    sweep_converged: tuple
    ranges: dict
    baseline: dict | None
    reasons: tuple
    tried: tuple
    response: Any
    objective_met: bool = True
    phase_margin: float = math.nan
    plant_time_scale: float = math.nan
    warnings: tuple = ()

    @property
    def certified(self) -> bool:
        """The design's eps and gamma are both certified (surrogate loop, varying ``b``)."""
        return bool(self.eps_certificate.certified and self.gamma_certificate.certified)

    def to_dict(self) -> dict:
        """Strict JSON: the design, certificates, predictions and reasons (no trajectories).

        Examples
        --------
        >>> import json, fl_design as fl
        >>> d = fl.tune(fl.plants.pendulum(), reference=0.1, decays=[1]).to_dict()
        >>> json.loads(json.dumps(d, allow_nan=False))["status"]
        'converged'
        """
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "response"}
        est, ctrl = self.design.estimator, self.design.controller
        out["design"] = {"estimator": "ehgo", "rho": est.rho, "eps": est.eps, "T": est.T,
                         "coeffs": list(est.alphas), "gains": list(ctrl.gains),
                         "gamma": ctrl.gamma, "ki": ctrl.ki, "u_limits": ctrl.u_range}
        out["certified"] = self.certified
        return jsonable(out)

    def plot(self, **kwargs):
        """The check simulation (:meth:`fl_design.Response.plot`).

        Parameters
        ----------
        **kwargs
            Passed to :meth:`fl_design.Response.plot`.

        Returns
        -------
        matplotlib.figure.Figure

        Examples
        --------
        >>> import matplotlib; matplotlib.use("Agg")
        >>> import fl_design as fl
        >>> fig = fl.tune(fl.plants.pendulum(), reference=0.1, decays=[1]).plot()
        """
        return self.response.plot(**kwargs)

    def __repr__(self) -> str:
        est, ctrl = self.design.estimator, self.design.controller
        ok = sum(s in ("converged", "converging") for *_, s in self.sweep_converged)
        lines = [(f"Tuning ({self.objective}): T = {est.T:g} s, K = "
                 f"{tuple(round(k, 6) for k in ctrl.gains)}, gamma = {ctrl.gamma:.4g}, "
                 f"eps = {est.eps:.4g} s, u_limits = {ctrl.u_limits}"),
                 (f"certified: {self.certified} ({self.eps_certificate.covers} b); eps* "
                 f"certified {_num(self.eps_star_certified)}"),
                 (f"predicted: {self.status}, overshoot {_num(self.overshoot)} %, settling "
                 f"{_num(self.settling_time)} s, noise gain {_num(self.noise_gain)}"),
                 (f"sweep around it: {ok}/{len(self.sweep_converged)} runs converge; phase "
                  f"margin {_num(self.phase_margin)} deg")]
        lines += [f"WARNING: {w}" for w in self.warnings]
        return "\n  ".join(lines + list(self.reasons))


def _num(x) -> str:
    if x is None:
        return "-"
    return f"{x:.3g}" if math.isfinite(x) else str(x)


__all__ = ["Tuning"]
