"""The result of ``fl.tune(plant_class)``: a design for a whole class and what backs it.

Examples
--------
>>> from fl_design.tuning._class_tuning import ClassTuning
>>> "members" in ClassTuning.__dataclass_fields__
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .._json import jsonable


@dataclass(frozen=True, repr=False)
class ClassTuning:
    """A design proposed for every plant of a class (:func:`fl_design.tune` with a class).

    Parameters
    ----------
    design : Design
        EHGO + dynamic controller.
    plant_class : PlantClass
        The class it was designed and certified for.
    objective : str
        ``"least-noise"`` or ``"fastest"``.
    reference : float
        Step target of the member runs.
    time_scale : float
        The loop decay the gains were synthesized for [rad/s].
    eps_certificate : EpsCertificate
        :func:`fl_design.certify_eps` of the design over the class.
    eps_star_frozen : float
        The class's frozen-``b`` eps* at the design's gamma (an eigenvalue scan, no certificate).
    noise_gain : dict
        Per end of ``b``: rms ``u`` and rms ``y`` per unit rms white sensor noise.
    margins : tuple of LoopMargins
        Gain, phase, delay margins at the plant input at each end of ``b``.
    members : tuple of MemberRun
        Runs on class members (chains at the ends of ``b``, switching ``b``, ``a``'s corners).
    reasons : tuple of str
        One sentence per choice, with its numbers.
    tried : tuple of str
        Candidates or eps rejected, and why.
    uncovered : tuple of str
        What the certificate does not cover (:meth:`PlantClass.uncovered`).

    Examples
    --------
    See :func:`fl_design.tuning._tune_class.tune_class`.
    """

    design: Any
    plant_class: Any
    objective: str
    reference: float
    time_scale: float
    eps_certificate: Any
    eps_star_frozen: float
    noise_gain: dict
    margins: tuple
    members: tuple
    reasons: tuple
    tried: tuple
    uncovered: tuple

    @property
    def certified(self) -> bool:
        """The design's eps is certified for every plant of the class (its surrogate loop)."""
        return bool(self.eps_certificate.certified)

    @property
    def converged(self) -> bool:
        """Every member run converged (True when none was run)."""
        return all(m.converged for m in self.members)

    @property
    def status(self) -> str:
        """``"certified"``, ``"not certified"``, plus whether the member runs converge."""
        head = "certified" if self.certified else "not certified"
        if not self.members:
            return head
        n = sum(m.converged for m in self.members)
        return f"{head}; {n}/{len(self.members)} member runs converge"

    def to_dict(self) -> dict:
        """Strict JSON: design, class, certificate, margins, members, reasons.

        Examples
        --------
        >>> import json, fl_design as fl
        >>> from fl_design.tuning._tune_class import tune_class
        >>> t = tune_class(fl.PlantClass(rho=1, T=1e-3, b=(1, 2)), members=False)
        >>> json.loads(json.dumps(t.to_dict(), allow_nan=False))["certified"]
        True
        """
        est, ctrl = self.design.estimator, self.design.controller
        return jsonable({
            "design": {"estimator": "ehgo", "rho": est.rho, "eps": est.eps, "T": est.T,
                       "coeffs": list(est.alphas), "gains": list(ctrl.gains),
                       "gamma": ctrl.gamma, "ki": ctrl.ki, "u_limits": ctrl.u_range},
            "plant_class": self.plant_class.to_dict(), "objective": self.objective,
            "reference": self.reference, "time_scale": self.time_scale,
            "certified": self.certified, "certificate": self.eps_certificate.reason,
            "covers": self.eps_certificate.covers, "eps_star_frozen": self.eps_star_frozen,
            "noise_gain": self.noise_gain,
            "margins": [m.to_dict() for m in self.margins],
            "members": [m.to_dict() for m in self.members], "reasons": list(self.reasons),
            "tried": list(self.tried), "uncovered": list(self.uncovered)})

    def __repr__(self) -> str:
        est, ctrl = self.design.estimator, self.design.controller
        lines = [(f"ClassTuning ({self.objective}): T = {est.T:g} s, K = "
                  f"{tuple(round(k, 6) for k in ctrl.gains)}, gamma = {ctrl.gamma:.4g}, "
                  f"eps = {est.eps:.4g} s: {self.status}"),
                 f"certificate: {self.eps_certificate.reason}",
                 f"not covered: {', '.join(self.uncovered) or '-'}"]
        lines += list(self.reasons) + [m.line() for m in self.members]
        return "\n  ".join(lines)


def _num(x) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.3g}"


__all__ = ["ClassTuning"]
