"""A small library of benchmark plants, each a validated :class:`fl_design.Plant`.

================== ===== ===== ===================================== ==================
plant              n     rho   input range                           b range (region)
================== ===== ===== ===================================== ==================
trms_yaw()         2     2     u in [-2.5, 2.5]                      [3.6, 6.8]
trms_yaw(True)     3     3     u in [-2.5, 2.5]                      [3.6, 6.8]
pendulum()         2     2     u in [-20, 20]                        [1, 1]
flexible_joint()   4     4     u in [-10, 10]                        [418.48, 418.48]
================== ===== ===== ===================================== ==================

Parameters are keyword overrides, validated; symbols are real (states) and positive
(parameters), so that the derived expressions stay readable.

Examples
--------
>>> import fl_design as fl
>>> [fl.plants.trms_yaw().relative_degree(), fl.plants.flexible_joint().relative_degree()]
[2, 4]
"""

from __future__ import annotations

import math

import sympy as sp

from . import _validate as V
from .symbolic._plant import Plant


def _pos(**values) -> dict:
    return {k: V.positive(k, v) for k, v in values.items()}


def trms_yaw(motor_lag: bool = False, *, I2: float = 2e-2, a2: float = 0.02, b2: float = 0.09,
             B1: float = 0.1, B2: float = 0.01, delta: float = 1e-3, k2: float = 0.8,
             T21: float = 1.0, T20: float = 1.0, input_range=(-2.5, 2.5)) -> Plant:
    """Yaw axis of the Feedback Instruments TRMS 33-220 twin rotor (main rotor off), simplified.

    Model (structure of the manufacturer's manual, *Twin Rotor MIMO System Control
    Experiments 33-949S*, horizontal plane; parameter values as specified for fl_design)::

        I2 phi'' = a2 tau |tau| + b2 tau - B1 phi' - B2 tanh(phi'/delta)
        T21 tau' = k2 u - T20 tau          (motor_lag=True)
        tau      = k2 u / T20              (motor_lag=False: static motor)

    ``tau`` is the tail rotor's normalised momentum (thrust), the yaw friction is viscous plus a
    Coulomb term smoothed by ``tanh(phi'/delta)``. Output ``y = phi`` (yaw, rad).

    * states: ``(phi, phi_dot)`` (static motor, relative degree 2) or ``(phi, phi_dot, tau)``
      (motor lag, relative degree 3); input: ``u`` (tail motor voltage, normalised), in
      ``[-2.5, 2.5]``;
    * region: ``phi in [-pi, pi]`` (a full turn around the rest position; the real rig's cable
      allows a little less, and b does not depend on phi), ``phi_dot in [-3, 3]`` rad/s (the
      steady yaw rate at full thrust is about 2.5 rad/s), ``tau in [-2, 2]`` (= ``k2 u / T20``
      over the input range);
    * input coefficient: ``b = (2 a2 |tau| + b2) k2 / (T20 I2)`` with ``tau = k2 u/T20`` (static),
      ``b = (2 a2 |tau| + b2) k2 / (T21 I2)`` (motor lag); with the default values both range over
      ``[3.6, 6.8]`` (``|tau| in [0, 2]``).

    Parameters
    ----------
    motor_lag : bool, optional
        Include the first-order tail-motor dynamics (state ``tau``).
    I2 : float, optional
        Yaw moment of inertia, 2e-2 kg m^2.
    a2, b2 : float, optional
        Quadratic and linear thrust-to-torque coefficients (0.02, 0.09); ``a2 >= 0``, ``b2 > 0``.
    B1 : float, optional
        Viscous friction coefficient (0.1), >= 0.
    B2 : float, optional
        Coulomb friction level (0.01), >= 0.
    delta : float, optional
        Width of the tanh smoothing of the Coulomb term (1e-3 rad/s), > 0.
    k2 : float, optional
        Motor gain (0.8), > 0.
    T21 : float, optional
        Motor time constant (1 s), > 0; used only with ``motor_lag=True``.
    T20 : float, optional
        Motor denominator coefficient (1), > 0.
    input_range : (lo, hi), optional
        Admissible inputs (default ``(-2.5, 2.5)``).

    Returns
    -------
    Plant

    Examples
    --------
    >>> import fl_design as fl
    >>> p = fl.plants.trms_yaw(motor_lag=True)
    >>> p.relative_degree(), p.b_bounds()
    (3, (3.6..., 6.8...))
    """
    motor_lag = V.boolean("motor_lag", motor_lag)
    vals = _pos(I2=I2, delta=delta, k2=k2, T20=T20, b2=b2)
    vals.update({k: V.nonnegative(k, v) for k, v in {"a2": a2, "B1": B1, "B2": B2}.items()})
    t21 = V.positive("T21", T21)  # checked even when unused: a typo is never silently ignored
    if motor_lag:
        vals["T21"] = t21
    sym = {k: sp.Symbol(k, positive=True) for k in vals}
    phi, w, tau, u = sp.symbols("phi phi_dot tau u", real=True)
    s = sym
    torque = lambda t: s["a2"] * t * sp.Abs(t) + s["b2"] * t
    friction = s["B1"] * w + s["B2"] * sp.tanh(w / s["delta"])
    region = {phi: (-math.pi, math.pi), w: (-3.0, 3.0)}
    if motor_lag:
        rhs = [w, (torque(tau) - friction) / s["I2"], (s["k2"] * u - s["T20"] * tau) / s["T21"]]
        states = [phi, w, tau]
        region[tau] = (-2.0, 2.0)
    else:
        rhs = [w, (torque(s["k2"] * u / s["T20"]) - friction) / s["I2"]]
        states = [phi, w]
    return Plant.from_ode(states, u, rhs, phi, params={sym[k]: v for k, v in vals.items()},
                          name="trms_yaw_motor_lag" if motor_lag else "trms_yaw",
                          input_range=input_range, region=region)


def pendulum(*, g: float = 9.81, l: float = 1.0, c: float = 0.5, b: float = 1.0,
             input_range=(-20.0, 20.0)) -> Plant:
    """Damped pendulum driven by a torque: ``theta'' = -(g/l) sin(theta) - c theta' + b u``.

    A textbook benchmark (e.g. Khalil, *Nonlinear Systems*, 3rd ed., Sec. 1.2.1) with a
    1 m pendulum (``g/l = 9.81`` s^-2, natural frequency 3.13 rad/s), light damping
    ``c = 0.5`` s^-1 (damping ratio 0.08: visibly oscillatory in open loop) and ``b = 1/(m l^2)``
    for 1 kg; the default input range ``[-20, 20]`` is twice the largest gravity torque, so every
    angle can be held.

    * states: ``(theta, theta_dot)``; input ``u`` (torque); output ``y = theta``;
      relative degree 2;
    * region: ``theta in [-pi, pi]``, ``theta_dot in [-10, 10]`` rad/s;
    * input coefficient ``b`` constant: b range ``[b, b]`` = ``[1, 1]`` by default.

    Parameters
    ----------
    g : float, optional
        Gravity, 9.81 m/s^2 (> 0).
    l : float, optional
        Length, 1 m (> 0).
    c : float, optional
        Damping per unit inertia, 0.5 1/s (>= 0).
    b : float, optional
        Input gain ``1/(m l^2)``, 1 (> 0).
    input_range : (lo, hi), optional
        Admissible torques (default ``(-20, 20)``).

    Returns
    -------
    Plant

    Examples
    --------
    >>> import fl_design as fl
    >>> p = fl.plants.pendulum(c=0.1)
    >>> p.relative_degree(), p.b_bounds()
    (2, (1.0, 1.0))
    """
    vals = _pos(g=g, l=l, b=b)
    vals["c"] = V.nonnegative("c", c)
    s = {k: sp.Symbol(k, positive=True) for k in vals}
    th, om, u = sp.symbols("theta theta_dot u", real=True)
    rhs = [om, -(s["g"] / s["l"]) * sp.sin(th) - s["c"] * om + s["b"] * u]
    return Plant.from_ode([th, om], u, rhs, th, params={s[k]: v for k, v in vals.items()},
                          name="pendulum", input_range=input_range,
                          region={th: (-math.pi, math.pi), om: (-10.0, 10.0)})


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

    Examples
    --------
    >>> import fl_design as fl
    >>> p = fl.plants.flexible_joint()
    >>> p.relative_degree(), [round(v, 2) for v in p.b_bounds()]
    (4, [418.48, 418.48])
    """
    vals = _pos(Jm=Jm, Jl=Jl, m=m, h=h, k=k, Ktau=Ktau, g=g)
    vals["B"] = V.nonnegative("B", B)
    s = {name: sp.Symbol(name, positive=True) for name in vals}
    q1, w1, q2, w2, u = sp.symbols("q1 q1_dot q2 q2_dot u", real=True)
    spring = s["k"] * (q1 - q2)
    rhs = [w1, (-s["m"] * s["g"] * s["h"] * sp.sin(q1) - spring) / s["Jl"],
           w2, (s["Ktau"] * u - s["B"] * w2 + spring) / s["Jm"]]
    return Plant.from_ode([q1, w1, q2, w2], u, rhs, q1,
                          params={s[name]: v for name, v in vals.items()},
                          name="flexible_joint", input_range=input_range,
                          region={q1: (-math.pi, math.pi), w1: (-10.0, 10.0),
                                  q2: (-math.pi, math.pi), w2: (-10.0, 10.0)})


__all__ = ["flexible_joint", "pendulum", "trms_yaw"]
