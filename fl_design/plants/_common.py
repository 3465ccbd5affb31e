"""Helpers shared by the plant modules: validated parameters, a plant from its recipe.

A library plant is built from a *recipe* (:mod:`fl_design.symbolic._recipe`): the module-level
function writing its SymPy definition, its validated parameters and options. Its derivations are
cached under the recipe's key, so a plant found in the cache is built without SymPy.

Examples
--------
>>> from fl_design.plants._common import validated_params
>>> validated_params({"m": 0.5, "l": 1}, {"c": 0})
{'m': 0.5, 'l': 1.0, 'c': 0.0}
"""

from __future__ import annotations

from .. import _validate as V
from ..symbolic._plant import Plant, _from_recipe
from ..symbolic._recipe import Recipe


def validated_params(positive: dict, nonnegative: dict | None = None) -> dict:
    """``{name: float}``: ``positive`` values checked finite and > 0, then ``nonnegative`` ones >= 0.

    A bad value raises a ``ParameterError`` naming it; the order (positive first) is the order
    of the plant's recipe and so of its cache key.

    Parameters
    ----------
    positive : dict
        ``{name: value}`` that must be > 0.
    nonnegative : dict, optional
        ``{name: value}`` that may also be 0 (friction, damping).

    Returns
    -------
    dict
        Every name with its value as a float.

    Examples
    --------
    >>> from fl_design.plants._common import validated_params
    >>> validated_params({"g": 9.81}, {"c": 0})
    {'g': 9.81, 'c': 0.0}
    """
    vals = {k: V.positive(k, v) for k, v in positive.items()}
    vals.update({k: V.nonnegative(k, v) for k, v in (nonnegative or {}).items()})
    return vals


def param_symbols(params: dict) -> dict:
    """``{name: sympy.Symbol(name, positive=True)}``: a definition's symbols for ``params``.

    Parameters
    ----------
    params : dict
        ``{name: float}`` validated by the plant's factory.

    Returns
    -------
    dict
        One positive real symbol per parameter name (SymPy simplifies knowing the sign).

    Examples
    --------
    >>> from fl_design.plants._common import param_symbols
    >>> param_symbols({"g": 9.81})["g"].is_positive
    True
    """
    import sympy as sp

    return {k: sp.Symbol(k, positive=True) for k in params}


def definition_dict(symbols: dict, params: dict, **parts) -> dict:
    """What a definition function returns: ``parts`` and ``params`` keyed by ``symbols``.

    The contract of every ``*_definition(params, **options)`` of :mod:`fl_design.plants`: it
    takes the values its factory validated (:func:`validated_params`) and returns ``states``,
    ``input``, ``rhs``, ``output``, ``params`` (``{Symbol: value}``), ``region`` and, where
    the operating point is not the origin, ``operating_point``
    (:func:`fl_design.symbolic._definition.define` reads them).

    Parameters
    ----------
    symbols : dict
        ``{name: Symbol}`` from :func:`param_symbols`.
    params : dict
        ``{name: float}`` the definition was called with.
    **parts
        ``states``, ``input``, ``rhs``, ``output``, ``region`` (and ``operating_point``).

    Returns
    -------
    dict
        The keyword arguments of :class:`fl_design.Plant`.

    Examples
    --------
    >>> from fl_design.plants._common import definition_dict, param_symbols
    >>> s = param_symbols({"k": 2.0})
    >>> definition_dict(s, {"k": 2.0}, output="x")
    {'output': 'x', 'params': {k: 2.0}}
    """
    return {**parts, "params": {symbols[k]: v for k, v in params.items()}}


def library_plant(definition, *, name: str, params: dict, input_range, **options) -> Plant:
    """The plant written by ``definition(params, **options)``, known by its recipe.

    Parameters
    ----------
    definition : callable
        A module-level function of fl_design returning the SymPy definition (the contract:
        :func:`definition_dict`).
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
        Built from its recipe, derivations read from the cache when there.

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


__all__ = ["definition_dict", "library_plant", "param_symbols", "validated_params"]
