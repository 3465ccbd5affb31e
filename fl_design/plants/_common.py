"""Helpers shared by the plant modules: validated parameters, a plant from its recipe.

A library plant is built from a *recipe* (:mod:`fl_design.symbolic._recipe`): the module-level
function writing its SymPy definition, its validated parameters and options. Its derivations are
cached under the recipe's key, so a plant found in the cache is built without SymPy.

Examples
--------
>>> from fl_design.plants._common import positive_params
>>> positive_params(m=0.5, l=1)
{'m': 0.5, 'l': 1.0}
"""

from __future__ import annotations

from .. import _validate as V
from ..symbolic._plant import Plant, _from_recipe
from ..symbolic._recipe import Recipe


def positive_params(**values) -> dict:
    """``{name: float}`` with every value checked finite and > 0 (a ``ParameterError`` names it).

    Parameters
    ----------
    **values : float
        ``name=value`` pairs.

    Returns
    -------
    dict

    Examples
    --------
    >>> from fl_design.plants._common import positive_params
    >>> positive_params(g=9.81)
    {'g': 9.81}
    """
    return {k: V.positive(k, v) for k, v in values.items()}


def library_plant(definition, *, name: str, params: dict, input_range, **options) -> Plant:
    """The plant written by ``definition(params, **options)``, known by its recipe.

    Parameters
    ----------
    definition : callable
        A module-level function of fl_design returning the SymPy definition (``states``,
        ``input``, ``rhs``, ``output``, ``params``, ``region``, optionally ``operating_point``).
    name : str
        The plant's label.
    params : dict
        ``{name: float}``, validated.
    input_range : (lo, hi) or float or None
        Admissible inputs (validated here).
    **options
        Keyword options of ``definition`` (plain values).

    Returns
    -------
    Plant

    Examples
    --------
    >>> from fl_design.plants._common import library_plant
    >>> from fl_design.plants._pendulums import pendulum_definition
    >>> p = library_plant(pendulum_definition, name="pendulum", input_range=(-20, 20),
    ...                   params={"g": 9.81, "l": 1.0, "b": 1.0, "c": 0.5})
    >>> p.relative_degree(), p.u_eq
    (2, 0.0)
    """
    recipe = Recipe(f"{definition.__module__}:{definition.__qualname__}",
                    tuple((k, float(v)) for k, v in params.items()),
                    tuple(sorted(options.items())), name=name,
                    input_range=V.interval("input_range", input_range))
    return _from_recipe(recipe)


__all__ = ["library_plant", "positive_params"]
