"""Spong's single-link robot with a flexible joint (relative degree 4)."""

from __future__ import annotations

import math

from ..symbolic._plant import Plant
from ._common import definition_dict, library_plant, param_symbols, validated_params


def flexible_joint(*, Jm: float = 3.7e-3, Jl: float = 9.3e-3, m: float = 0.21, h: float = 0.155,
                   k: float = 0.18, B: float = 4.6e-2, Ktau: float = 8e-2, g: float = 9.81,
                   input_range=(-10.0, 10.0)) -> Plant:
    """Single-link robot with a flexible joint (Spong's model), output the link angle.

    Model (M. W. Spong, "Modeling and control of elastic joint robots", ASME J. Dyn. Syst.
    Meas. Control 109, 1987; parameter values as specified for fl_design)::

        Jl q1'' + m g h sin(q1) + k (q1 - q2) = 0
        Jm q2'' + B q2' - k (q1 - q2)        = Ktau u

    * states: ``(q1, q1_dot, q2, q2_dot)`` (link and motor angles and rates); input ``u``
      (motor command, ``Ktau u`` is the motor torque) in ``[-10, 10]``; output ``y = q1``;
      relative degree 4 = n (no zero dynamics);
    * region: ``q1, q2 in [-pi, pi]``, ``q1_dot, q2_dot in [-10, 10]`` rad/s;
    * input coefficient ``b = k Ktau / (Jl Jm)``, constant: 418.48 with the default values.

    Parameters
    ----------
    Jm : float, optional
        Motor inertia, 3.7e-3 kg m^2.
    Jl : float, optional
        Link inertia, 9.3e-3 kg m^2.
    m : float, optional
        Link mass, 0.21 kg.
    h : float, optional
        Distance of the link's centre of mass from the joint, 0.155 m.
    k : float, optional
        Joint stiffness, 0.18 N m/rad.
    B : float, optional
        Motor viscous friction, 4.6e-2 N m s/rad (>= 0).
    Ktau : float, optional
        Input gain, 8e-2 N m per input unit.
    g : float, optional
        Gravity, 9.81 m/s^2.
    input_range : (lo, hi), optional
        Admissible inputs (default ``(-10, 10)``; ``Ktau * 10 = 0.8`` N m exceeds the largest
        gravity torque ``m g h = 0.32`` N m).

    Returns
    -------
    Plant
        Relative degree 4 = n (no zero dynamics), constant ``b = k Ktau / (Jl Jm)``.

    Examples
    --------
    >>> import fl_design as fl
    >>> p = fl.plants.flexible_joint()
    >>> p.relative_degree(), [round(v, 2) for v in p.b_bounds()]
    (4, [418.48, 418.48])
    """
    vals = validated_params({"Jm": Jm, "Jl": Jl, "m": m, "h": h, "k": k, "Ktau": Ktau, "g": g},
                            {"B": B})
    return library_plant(flexible_joint_definition, params=vals, name="flexible_joint",
                         input_range=input_range)


def flexible_joint_definition(params: dict) -> dict:
    """Spong's link and motor equations in SymPy, output the link angle ``q1``.

    The definition of :func:`flexible_joint` (see there for the model), from the ``params`` it
    validated; what it returns: :func:`~fl_design.plants._common.definition_dict`.

    Examples
    --------
    >>> from fl_design.plants._flexible_joint import flexible_joint_definition
    >>> flexible_joint_definition(dict(fl.plants.flexible_joint()._recipe.params))["states"]
    [q1, q1_dot, q2, q2_dot]
    """
    import sympy as sp

    s = param_symbols(params)
    q1, w1, q2, w2, u = sp.symbols("q1 q1_dot q2 q2_dot u", real=True)
    spring = s["k"] * (q1 - q2)
    rhs = [w1, (-s["m"] * s["g"] * s["h"] * sp.sin(q1) - spring) / s["Jl"],
           w2, (s["Ktau"] * u - s["B"] * w2 + spring) / s["Jm"]]
    return definition_dict(s, params, states=[q1, w1, q2, w2], input=u, rhs=rhs, output=q1,
                           region={q1: (-math.pi, math.pi), w1: (-10.0, 10.0),
                                   q2: (-math.pi, math.pi), w2: (-10.0, 10.0)})


__all__ = ["flexible_joint"]
