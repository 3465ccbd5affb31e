"""Derivation layer (SymPy): the plant, its normal form and b-range, the sampled-plant series.

Modules: ``_plant`` (:class:`Plant`), ``_normal_form`` (relative degree by Lie derivatives,
:class:`NormalForm`, zero dynamics, b-bounds), ``_bridge`` (the one SymPy -> CasADi bridge),
``_discretization`` (exact Taylor/Lie series ``F^e``, the approximate model ``F^a``, residuals).

Examples
--------
>>> from fl_design.symbolic import approximate_extended_model
>>> approximate_extended_model(2).shape
(3, 3)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_attributes

# public name -> the module defining it, imported on first use (PEP 562): a process that only
# loads a cached library plant needs ``_plant`` (no SymPy), not the derivation modules
_LAZY = {"to_casadi": "_bridge", "Discretization": "_discretization",
         "approximate_extended_model": "_discretization", "chain_states": "_discretization",
         "lie_series_terms": "_discretization", "sigma_symbol": "_discretization",
         "taylor_discretization": "_discretization", "Equilibrium": "_equilibrium",
         "InternalDynamics": "_normal_form", "NormalForm": "_normal_form", "Plant": "_plant",
         "PlantFunctions": "_casadi_functions",
         "check_assumptions": "_assumptions", "assumption_failures": "_assumptions"}

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from ._assumptions import assumption_failures, check_assumptions
    from ._bridge import to_casadi
    from ._casadi_functions import PlantFunctions
    from ._discretization import (
        Discretization,
        approximate_extended_model,
        chain_states,
        lie_series_terms,
        sigma_symbol,
        taylor_discretization,
    )
    from ._equilibrium import Equilibrium
    from ._normal_form import InternalDynamics, NormalForm
    from ._plant import Plant


__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals())


__all__ = [
    "Discretization",
    "Equilibrium",
    "InternalDynamics",
    "NormalForm",
    "Plant",
    "PlantFunctions",
    "approximate_extended_model",
    "assumption_failures",
    "chain_states",
    "check_assumptions",
    "lie_series_terms",
    "sigma_symbol",
    "taylor_discretization",
    "to_casadi",
]
