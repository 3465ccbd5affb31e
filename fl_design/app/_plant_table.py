"""``[plant]``: a library plant by name, or a plant written as expressions (strings).

The library's names are :data:`LIBRARY` (``--plant`` takes the same); an expression plant's
strings are parsed later by the grammar of :mod:`fl_design.symbolic._grammar`
(:func:`fl_design.app.build_plant`), never evaluated.

Examples
--------
>>> from fl_design.app._plant_table import PlantTable
>>> PlantTable(library="maglev").output_unit
'output units'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from .. import _validate as V
from ..errors import ParameterError
from ._tables import mapping, set_fields

#: Library plants by config name (``[plant] library``, ``--plant``) -> (module attribute, kwargs).
LIBRARY = {"trms": ("trms_yaw", {}), "trms-lag": ("trms_yaw", {"motor_lag": True}),
           "pendulum": ("pendulum", {}), "flexible-joint": ("flexible_joint", {}),
           "cart-pendulum": ("cart_pendulum", {}), "maglev": ("maglev", {})}

#: Keys that only a plant from expressions takes (a library plant has its own).
_EXPRESSION_ONLY = ("name", "params", "region", "input_range", "operating_point")


@dataclass(frozen=True)
class PlantTable:
    """``[plant]``: a library plant by name, or a plant written as expressions.

    Parameters
    ----------
    library : str, optional
        A library plant: trms | trms-lag | pendulum | flexible-joint | cart-pendulum | maglev.
    motor_lag : bool, optional
        With library = "trms": add the motor's lag (the same as library = "trms-lag").
    name : str, optional
        A label for the report (a plant from expressions; default "plant").
    states : tuple of str, optional
        State names (a plant from expressions: states, input, rhs and output).
    input : str, optional
        The input's name.
    rhs : tuple of str, optional
        x' = f(x, u), one expression per state (+ - * / ** sin cos exp ...).
    output : str, optional
        y = h(x), an expression.
    params : mapping, optional
        Numbers for the other names of the expressions.
    region : mapping, optional
        Where the plant is used, [lo, hi] per state: gives the b-range of the certificates.
    input_range : (float, float), optional
        What the actuator can give.
    operating_point : mapping, optional
        Held states (or y); the others and u_eq are solved.
    output_unit, input_unit : str, optional
        Units of y and u (axis labels of the report).

    Raises
    ------
    ParameterError
        An unknown library name, library given with expressions, an incomplete plant from
        expressions, a name that is not an identifier, a non-finite number.

    Examples
    --------
    >>> from fl_design.app._plant_table import PlantTable
    >>> PlantTable(states=["x"], input="u", rhs=["-x + u"], output="x").expression
    True
    """

    library: str | None = None
    motor_lag: bool = False
    name: str | None = None
    states: tuple | None = None
    input: str | None = None
    rhs: tuple | None = None
    output: str | None = None
    params: Mapping | None = None
    region: Mapping | None = None
    input_range: tuple | None = None
    operating_point: Mapping | None = None
    output_unit: str = "output units"
    input_unit: str = "input units"

    def __post_init__(self) -> None:
        V.boolean("motor_lag", self.motor_lag)
        for key in ("output_unit", "input_unit") + (("name",) if self.name is not None else ()):
            V.instance(key, getattr(self, key), str, "a string")
            if len(getattr(self, key)) > 200:  # printed in every figure (long text: minutes)
                raise ParameterError(f"{key} has {len(getattr(self, key))} characters, above "
                                     "the limit of 200 (it is printed in every figure): "
                                     "shorten it")
        if self.motor_lag and self.library not in (None, "trms"):
            raise ParameterError(f'motor_lag = true applies to library = "trms" only (the '
                                 f"TRMS's motor lag), got library = {self.library!r}")
        if not self.expression:
            V.choice("library", "trms" if self.library is None else self.library, LIBRARY)
            if self.library is None:
                set_fields(self, library="trms")
            extra = [k for k in _EXPRESSION_ONLY if getattr(self, k) is not None]
            if extra:
                raise ParameterError(f"{extra[0]} is a key of a plant from expressions; the "
                                     f"library plant {self.library!r} has its own (remove it, "
                                     "or write the plant as states, input, rhs and output)")
            return
        if self.motor_lag:
            raise ParameterError('motor_lag = true applies to library = "trms" only, not to '
                                 "a plant from expressions (write the lag into rhs)")
        if self.library is not None:
            raise ParameterError(f"library = {self.library!r} and a plant from expressions "
                                 "(states, input, rhs, output) are given: give one of them")
        missing = [k for k in ("states", "input", "rhs", "output") if getattr(self, k) is None]
        if missing:
            raise ParameterError(f"a plant from expressions needs {missing[0]!r} (states, "
                                 "input, rhs and output as strings)")
        if isinstance(self.states, str) or not isinstance(self.states, (list, tuple)):
            raise ParameterError(f"states must be an array of names, got {V.short(self.states)}")
        if isinstance(self.rhs, str) or not isinstance(self.rhs, (list, tuple)):
            raise ParameterError(f"rhs must be an array of expressions, got {V.short(self.rhs)}")
        set_fields(self, states=tuple(V.identifier("states", s) for s in self.states),
             input=V.identifier("input", self.input),
             rhs=tuple(V.instance(f"rhs[{i}]", e, str, "an expression (a string)")
                       for i, e in enumerate(self.rhs)),
             output=V.instance("output", self.output, str, "an expression (a string)"))
        number = V.real_scalar
        if self.params is not None:
            set_fields(self, params=mapping("params", self.params, number))
        if self.region is not None:
            set_fields(self, region=mapping("region", self.region,
                                       lambda n, v: V.real_tuple(n, v, length=2)))
        if self.operating_point is not None:
            set_fields(self, operating_point=mapping("operating_point", self.operating_point, number))
        if self.input_range is not None:
            set_fields(self, input_range=V.real_tuple("input_range", self.input_range, length=2))

    @property
    def expression(self) -> bool:
        """True for a plant written as expressions (not a library plant)."""
        return any(getattr(self, k) is not None for k in ("states", "input", "rhs", "output"))


__all__ = ["LIBRARY", "PlantTable"]
