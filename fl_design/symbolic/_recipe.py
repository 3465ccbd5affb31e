"""A library plant's recipe: what defines it, known without SymPy.

A plant of :mod:`fl_design.plants` is determined by the function that writes its SymPy definition
(``"module:function"``), its validated parameter values, its keyword options, name and input
range, and, after :meth:`fl_design.Plant.with_params`, the operating point it holds. A
:class:`Recipe` records exactly these (plain Python values), so that the plant's cache key
(:meth:`Recipe.key`) is known before any SymPy expression is built: a process that finds every
derived quantity in the cache (:mod:`fl_design.symbolic._derivation_cache`) never imports SymPy.
The key is the SHA-256 of the recipe's values (floats as ``float.hex``), the deriving code
(:func:`~fl_design.symbolic._derivation_cache.code_version`) and the sources of the package that
defines the plant, so that an edited plant module never reads a stale entry.

Examples
--------
>>> from fl_design.symbolic._recipe import Recipe
>>> r = Recipe("fl_design.plants._pendulums:pendulum_definition", (("g", 9.81),), name="p")
>>> len(r.key()), r.key() == Recipe(r.definition, (("g", 9.82),), name="p").key()
(64, False)
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import sys
from dataclasses import dataclass
from pathlib import Path

from ..errors import PlantDefinitionError
from ._derivation_cache import code_version, versions_and_sources

#: Tag of the recipe keys (bumped when the meaning of a recipe's fields changes).
FORMAT = "fl_design plant recipe 1"
_PLAIN = (bool, int, float, str, type(None))


def _text(value) -> str:
    """Exact text of a plain value (floats as ``float.hex``, so no digit is lost)."""
    if isinstance(value, float):
        return value.hex()
    if isinstance(value, (tuple, list)):
        return "(" + ",".join(_text(v) for v in value) + ")"
    return repr(value)


@functools.cache
def package_version(folder: str) -> str:
    """SHA-256 of the ``*.py`` sources in ``folder`` (the package defining a plant).

    Parameters
    ----------
    folder : str
        The package's directory (only its top-level ``*.py`` files count).

    Returns
    -------
    str
        64 hexadecimal digits (cached per process; ``package_version.__wrapped__`` re-reads).

    Examples
    --------
    >>> import fl_design.plants as plants
    >>> from pathlib import Path
    >>> from fl_design.symbolic._recipe import package_version
    >>> len(package_version(str(Path(plants.__file__).parent)))
    64
    """
    return versions_and_sources(("plant sources",), (), list(Path(folder).glob("*.py")))


@dataclass(frozen=True)
class Recipe:
    """How to build a library plant's SymPy definition, and the key of its derivations.

    Parameters
    ----------
    definition : str
        ``"module:function"``, a function of a module inside fl_design taking ``(params,
        **options)`` and returning the keyword arguments of :class:`fl_design.Plant` except
        ``params`` values, ``name`` and ``input_range`` (``states``, ``input``, ``rhs``,
        ``output``, ``params`` as ``{Symbol: value}``, ``region``, ``operating_point``).
    params : tuple of (str, float)
        Validated parameter values, in the plant's order.
    options : tuple of (str, value), optional
        Keyword options of the definition (bool, int, float, str or None).
    name : str, optional
        The plant's label.
    input_range : (float, float) or None, optional
        Validated input range.
    operating_point : tuple of (str, float), optional
        Every state held at this value (replaces the definition's operating point; set by
        :meth:`fl_design.Plant.with_params`).

    Examples
    --------
    >>> from fl_design.symbolic._recipe import Recipe
    >>> r = Recipe("fl_design.plants._pendulums:pendulum_definition",
    ...            (("g", 9.81), ("l", 1.0), ("b", 1.0), ("c", 0.5)), name="pendulum")
    >>> sorted(r.build())
    ['input', 'output', 'params', 'region', 'rhs', 'states']
    """

    definition: str
    params: tuple = ()
    options: tuple = ()
    name: str = "plant"
    input_range: tuple | None = None
    operating_point: tuple | None = None

    def __post_init__(self):
        module, _, function = self.definition.partition(":")
        if not (module.startswith("fl_design.") and function.isidentifier()):
            raise PlantDefinitionError(
                f"a recipe's definition must be 'module:function' inside fl_design, got "
                f"{self.definition!r}")
        for kind, pairs in (("params", self.params), ("options", self.options),
                            ("operating_point", self.operating_point or ())):
            bad = [p for p in pairs if not (isinstance(p, tuple) and len(p) == 2 and
                                            isinstance(p[0], str) and isinstance(p[1], _PLAIN))]
            if bad:
                raise PlantDefinitionError(
                    f"a recipe's {kind} must be (name, plain value) pairs, got {bad!r}")

    def _function(self):
        module, _, function = self.definition.partition(":")
        return getattr(importlib.import_module(module), function)

    def build(self) -> dict:
        """The SymPy definition: the keyword arguments of :class:`fl_design.Plant`.

        Returns
        -------
        dict
            ``states``, ``input``, ``rhs``, ``output``, ``params``, ``region`` and, when the plant
            holds one, ``operating_point``.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.plants.pendulum()._recipe.build()["output"]
        theta
        """
        kw = self._function()(dict(self.params), **dict(self.options))
        if self.operating_point is not None:
            kw["operating_point"] = dict(self.operating_point)
        return kw

    def key(self, code: str | None = None) -> str:
        """SHA-256 of the recipe, the deriving code and the plant's package sources.

        Parameters
        ----------
        code : str, optional
            The code version (default: :func:`~fl_design.symbolic._derivation_cache.code_version`
            and :func:`package_version` of the module defining the plant).

        Returns
        -------
        str
            64 hexadecimal digits: the name of the plant's derivations in the cache.

        Examples
        --------
        >>> import fl_design as fl
        >>> r = fl.plants.pendulum()._recipe
        >>> r.key() == r.key() != r.key(code="0" * 64)
        True
        """
        if code is None:
            module = self.definition.partition(":")[0]
            importlib.import_module(module)
            code = code_version() + package_version(str(Path(sys.modules[module].__file__).parent))
        parts = [FORMAT, code, self.definition, _text(self.name), _text(self.input_range),
                 *(f"{k}={_text(v)}" for k, v in self.params), "options",
                 *(f"{k}={_text(v)}" for k, v in self.options), "operating point",
                 _text(self.operating_point)]
        return hashlib.sha256("\n".join(parts).encode()).hexdigest()


__all__ = ["FORMAT", "Recipe", "package_version"]
