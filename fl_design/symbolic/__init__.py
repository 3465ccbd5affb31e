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

from ._bridge import to_casadi
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
from ._plant import Plant, PlantFunctions

__all__ = [
    "Discretization",
    "Equilibrium",
    "InternalDynamics",
    "NormalForm",
    "Plant",
    "PlantFunctions",
    "approximate_extended_model",
    "chain_states",
    "lie_series_terms",
    "sigma_symbol",
    "taylor_discretization",
    "to_casadi",
]
