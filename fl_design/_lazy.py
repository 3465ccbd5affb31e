"""Names of a package loaded on first use (PEP 562), so that importing the package is cheap.

A package lists ``{name: submodule}`` and takes the module-level ``__getattr__`` and
``__dir__`` this gives it; the first access to a name imports its submodule and keeps the
value in the package's namespace (later accesses are plain lookups). ``fl_design.plants``
uses it so that building one plant imports only that plant's module, and
``fl_design.symbolic`` so that a plant loaded from the derivation cache imports no SymPy.

Examples
--------
>>> import fl_design.plants as plants
>>> "trms_yaw" in dir(plants)
True
"""

from __future__ import annotations

import importlib


def lazy_attributes(package: str, table: dict, namespace: dict):
    """``(__getattr__, __dir__)`` of a package whose names in ``table`` load on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    table : dict
        ``{name: submodule}`` (the submodule's name relative to the package, e.g.
        ``"_rotor"``).
    namespace : dict
        The package's ``globals()``: a loaded name is stored there.

    Returns
    -------
    (callable, callable)
        The module-level ``__getattr__`` and ``__dir__``.

    Examples
    --------
    >>> ns = {}
    >>> get, names = lazy_attributes("json", {"dumps": "encoder"}, ns)
    >>> "dumps" in names()
    True
    """

    def __getattr__(name: str):
        if name in table:
            value = getattr(importlib.import_module(f".{table[name]}", package), name)
            namespace[name] = value
            return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__
