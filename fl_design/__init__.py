"""fl_design: model-free control of feedback-linearizable SISO plants.

An extended high-gain observer (EHGO) estimates the output, its derivatives and the lumped term
``sigma = a(w, x) + b(w, x) u``; the dynamic controller ``u(k+1) = u(k) + gamma (v - sigmahat)``
replaces the unknown feedback-linearizing input (Shenoy, Saradagi, Pasumarthy, Chellaboina).

Public names are loaded lazily so that ``import fl_design`` stays fast (SymPy and CasADi are
imported only by the modules that use them).

Examples
--------
>>> import fl_design as fl
>>> plant = fl.plants.trms_yaw()
>>> plant.relative_degree()
2
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from . import errors

__version__ = "0.1.0"

# public name -> module that defines it (None: the sub-module or sub-package itself)
_LAZY = {
    "certify_step": "analysis._step_cert",
    "Plant": "symbolic",
    "Equilibrium": "symbolic",
    "NormalForm": "symbolic",
    "Discretization": "symbolic",
    "taylor_discretization": "symbolic",
    "approximate_extended_model": "symbolic",
    "EHGO": "design",
    "LeastSquaresEstimator": "design",
    "DynamicController": "design",
    "gains_from_poles": "design",
    "lqr_gains": "design",
    "Design": "design",
    "read_telemetry": "codegen",
    "simulate": "sim",
    "Scenario": "sim",
    "Noise": "sim",
    "Classifier": "sim",
    "RK4": "sim",
    "Cvodes": "sim",
    "Kernel": "sim",
    "Disturbance": "sim",
    "Step": "sim",
    "Sine": "sim",
    "Response": "sim",
    "sweep": "sim",
    "StabilityMap": "sim",
    "EpsStar": "sim",
    "EpsStarEstimate": "sim",
    "estimate_eps_star": "sim",
    "monte_carlo": "sim",
    "Ensemble": "sim._ensemble",
    "Uniform": "sim._family",
    "Normal": "sim._family",
    "RobustMap": "sim._robust_map",
    "SampledLinearization": "analysis",
    "sampled_linearization": "analysis",
    "linearized_eps_star": "analysis",
    "generate_c": "codegen",
    "CPackage": "codegen",
    "certify_lyapunov": "analysis",
    "synthesize_gains": "analysis",
    "certify_gamma": "analysis",
    "certify_eps": "analysis",
    "eps_star_curve": "analysis",
    "LyapunovCertificate": "analysis",
    "GainSynthesis": "analysis",
    "GammaCertificate": "analysis",
    "EpsCertificate": "analysis",
    "EpsStarCurve": "analysis",
    "PlantClass": "analysis._plant_class",
    "tune": "tuning",
    "identify": "identification._identify",
    "Tuning": "tuning",
    # sub-modules and layers
    "plants": None,
    "presets": None,
    "plotting": None,
    "symbolic": None,
    "design": None,
    "sim": None,
    "analysis": None,
    "tuning": None,
    "codegen": None,
    "app": None,
}

if TYPE_CHECKING:  # what IDEs and type checkers see; at run time names load on first use
    from . import analysis, app, codegen, design, plants, plotting, presets, sim, symbolic, tuning
    from .analysis import (
        EpsCertificate,
        EpsStarCurve,
        GainSynthesis,
        GammaCertificate,
        LyapunovCertificate,
        SampledLinearization,
        certify_eps,
        certify_gamma,
        certify_lyapunov,
        eps_star_curve,
        linearized_eps_star,
        sampled_linearization,
        synthesize_gains,
    )
    from .analysis._plant_class import PlantClass
    from .codegen import CPackage, generate_c
    from .design import (
        EHGO,
        Design,
        DynamicController,
        LeastSquaresEstimator,
        gains_from_poles,
        lqr_gains,
    )
    from .sim import (
        RK4,
        Classifier,
        Cvodes,
        Disturbance,
        EpsStar,
        EpsStarEstimate,
        Kernel,
        Noise,
        Response,
        Scenario,
        Sine,
        StabilityMap,
        Step,
        estimate_eps_star,
        monte_carlo,
        simulate,
        sweep,
    )
    from .sim._ensemble import Ensemble
    from .sim._family import Normal, Uniform
    from .sim._robust_map import RobustMap
    from .symbolic import (
        Discretization,
        Equilibrium,
        NormalForm,
        Plant,
        approximate_extended_model,
        taylor_discretization,
    )
    from .tuning import Tuning, tune


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'fl_design' has no attribute {name!r}")
    module_name = _LAZY[name]
    if module_name is None:
        value = importlib.import_module(f".{name}", __name__)
    else:
        value = getattr(importlib.import_module(f".{module_name}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(list(globals()) + list(_LAZY))


__all__ = ["errors", "__version__", *_LAZY]  # noqa: PLE0604 (names of the lazy table)
