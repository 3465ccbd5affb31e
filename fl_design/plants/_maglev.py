"""Magnetic levitation of a steel ball under an electromagnet: relative degree 3, ``b < 0``."""

from __future__ import annotations

from .. import _validate as V
from ..symbolic._plant import Plant
from ._common import definition_dict, library_plant, param_symbols, validated_params


def maglev(*, m: float = 0.068, C: float = 3.2654e-5, L: float = 0.4125, R: float = 11.0,
           g: float = 9.81, y0: float = 6e-3, input_range=(0.0, 24.0)) -> Plant:
    """A steel ball held below an electromagnet by the coil voltage; output the air gap.

    Model (the classic magnetic suspension: W. Barie and J. Chiasson, "Linear and nonlinear
    state-space controllers for magnetic levitation", *Int. J. Systems Science* 27(11), 1996;
    the Quanser MAGLEV rig's model, whose force constant ``K_m`` enters as ``C = K_m / 2``)::

        y'  = v
        m v' = m g - C i^2 / y^2          (y: gap below the magnet, measured downward)
        L i' = -R i + u                   (u: coil voltage)

    * states ``(y, v, i)`` (gap m, velocity m/s, coil current A); input ``u`` (V) in
      ``[0, 24]``; output ``y``: relative degree 3 = n (no zero dynamics);
    * input coefficient ``b = -2 C i / (m L y^2) < 0`` on the region (``i > 0``, ``y > 0``):
      pulling harder (more current) reduces the gap, so ``gamma`` must be negative. Default
      values: ``b in [-174.6, -18.19]`` over the region, ``-55.46`` at the operating point;
    * operating point: the ball held at ``y0`` (default 6 mm, Quanser's nominal gap): ``v = 0``,
      ``i0 = y0 sqrt(m g / C) = 0.8576`` A, ``u_eq = R i0 = 9.433`` V. Open loop it is unstable:
      linearized poles ``+-sqrt(2 g / y0) = +-57.2`` rad/s and the coil's ``-R / L = -26.7``;
    * region: ``y in [4, 8]`` mm, ``v in [-0.5, 0.5]`` m/s, ``i in [0.5, 1.2]`` A.

    Default parameters: the Quanser MAGLEV (a 2.54 cm steel ball, ``m = 0.068`` kg; coil
    ``L = 0.4125`` H, ``R = 11`` ohm = 10 ohm coil + 1 ohm current-sense resistor; force constant
    ``K_m = 6.5308e-5`` N m^2 / A^2, ``F = K_m i^2 / (2 y^2)``), as quoted in the Quanser
    MAGLEV user manual; supply ``[0, 24]`` V.

    Parameters
    ----------
    m : float, optional
        Ball mass, 0.068 kg.
    C : float, optional
        Force constant ``F = C i^2 / y^2``, 3.2654e-5 N m^2 / A^2.
    L : float, optional
        Coil inductance, 0.4125 H.
    R : float, optional
        Coil plus sense resistance, 11 ohm.
    g : float, optional
        Gravity, 9.81 m/s^2.
    y0 : float, optional
        Gap held at the operating point, 6e-3 m; inside the region ``[4, 8]`` mm.
    input_range : (lo, hi), optional
        Admissible coil voltages (default ``(0, 24)`` V).

    Returns
    -------
    Plant
        Relative degree 3 = n, ``b < 0``, held at the gap ``y0`` (not at the origin).

    Raises
    ------
    ParameterError
        A non-positive parameter.
    PlantDefinitionError
        ``y0`` outside the region, or an equilibrium current or voltage outside the region or
        input range.

    Examples
    --------
    >>> import fl_design as fl
    >>> p = fl.plants.maglev()
    >>> p.relative_degree(), p.x_op.round(4).tolist(), round(p.u_eq, 3)
    (3, [0.006, 0.0, 0.8576], 9.433)
    >>> [round(v, 2) for v in p.b_bounds()]
    [-174.62, -18.19]
    """
    vals = validated_params({"m": m, "C": C, "L": L, "R": R, "g": g})
    y_op = V.positive("y0", y0)
    return library_plant(maglev_definition, params=vals, name="maglev", input_range=input_range,
                         y0=y_op)


def maglev_definition(params: dict, *, y0: float) -> dict:
    """The SymPy definition of :func:`maglev` from its validated ``params``, held at gap ``y0``.

    The contract of a definition: :func:`~fl_design.plants._common.definition_dict`; this one
    also returns the ``operating_point`` ``{"y": y0}``.

    Examples
    --------
    >>> from fl_design.plants._maglev import maglev_definition
    >>> maglev_definition(dict(fl.plants.maglev()._recipe.params), y0=6e-3)["operating_point"]
    {'y': 0.006}
    """
    import sympy as sp

    s = param_symbols(params)
    y, v, i, u = sp.symbols("y v i u", real=True)
    rhs = [v, s["g"] - s["C"] * i ** 2 / (s["m"] * y ** 2), (u - s["R"] * i) / s["L"]]
    return definition_dict(s, params, states=[y, v, i], input=u, rhs=rhs, output=y,
                           region={y: (4e-3, 8e-3), v: (-0.5, 0.5), i: (0.5, 1.2)},
                           operating_point={"y": y0})


__all__ = ["maglev"]
