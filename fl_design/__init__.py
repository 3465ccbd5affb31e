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

from . import errors

__version__ = "0.1.0"

# public name -> module that defines it
_LAZY = {
    "Plant": "plant",
    "NormalForm": "normal_form",
    "plants": None,  # the sub-module itself
    "Discretization": "discretization",
    "taylor_discretization": "discretization",
    "approximate_extended_model": "discretization",
    "EHGO": "observer",
    "LeastSquaresEstimator": "least_squares",
    "DynamicController": "controller",
    "gains_from_poles": "controller",
    "lqr_gains": "controller",
    "Design": "design",
    "simulate": "simulation",
    "Response": "response",
    "sweep": "sweeps",
    "StabilityMap": "sweeps",
    "estimate_eps_star": "sweeps",
    "sampled_linearization": "linearization",
    "linearized_eps_star": "linearization",
}


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
