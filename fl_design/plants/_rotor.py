"""The yaw axis of the Feedback Instruments twin-rotor (TRMS), with and without the motor lag."""

from __future__ import annotations

import math

from .. import _validate as V
from ..symbolic._plant import Plant
from ._common import definition_dict, library_plant, param_symbols, validated_params


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

    **The linearization is optimistic here.** At rest (``phi' = 0``) the smoothed Coulomb term
    has slope ``B2 / delta = 10`` N m s/rad, 100 times the viscous ``B1``: the linearized plant
    is heavily damped (a pole at ``-(B1 + B2/delta) / I2 = -505`` 1/s), and the linearized
    sampled loop stays stable for every eps (:func:`fl_design.linearized_eps_star` returns the
    top of its range, 1). That slope holds only for ``|phi'| << delta = 1 mrad/s``: any real
    motion saturates the friction to a nearly constant ``+-B2``, a relay the observer has to
    follow, and the nonlinear loop falls into a limit cycle for much smaller eps. Measured
    (``tests/sim/test_library_loops.py``, 0.05 rad step, T = 1 ms): empirical eps* 0.148 with
    ``presets.paper_design(gamma=1e-2)`` and 0.088 with ``presets.trms_lag_design()`` (motor
    lag), against a linearized eps* >= 1 for both. The same friction slope makes the loop slow
    near rest: its slowest linear time constant is about ``0.07 / gamma`` (234 s at the paper's
    ``gamma = 3e-4``, 7.5 s at ``1e-2``).

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
        Relative degree 2, or 3 with ``motor_lag``; ``b`` grows with the thrust ``|tau|``.

    Examples
    --------
    >>> import fl_design as fl
    >>> p = fl.plants.trms_yaw(motor_lag=True)
    >>> p.relative_degree(), p.b_bounds()
    (3, (3.6..., 6.8...))
    """
    motor_lag = V.boolean("motor_lag", motor_lag)
    vals = validated_params({"I2": I2, "delta": delta, "k2": k2, "T20": T20, "b2": b2},
                            {"a2": a2, "B1": B1, "B2": B2})
    t21 = V.positive("T21", T21)  # checked even when unused: a typo is never silently ignored
    if motor_lag:
        vals["T21"] = t21
    return library_plant(trms_yaw_definition, params=vals,
                         name="trms_yaw_motor_lag" if motor_lag else "trms_yaw",
                         input_range=input_range, motor_lag=motor_lag)


def trms_yaw_definition(params: dict, *, motor_lag: bool) -> dict:
    """The SymPy definition of :func:`trms_yaw` from its validated ``params``.

    ``motor_lag`` adds the tail-motor state ``tau`` (and ``T21`` to ``params``). The contract
    of a definition: :func:`~fl_design.plants._common.definition_dict`.

    Examples
    --------
    >>> from fl_design.plants._rotor import trms_yaw_definition
    >>> trms_yaw_definition({"I2": 0.02, "delta": 1e-3, "k2": 0.8, "T20": 1.0, "b2": 0.09,
    ...                      "a2": 0.02, "B1": 0.1, "B2": 0.01}, motor_lag=False)["states"]
    [phi, phi_dot]
    """
    import sympy as sp

    s = param_symbols(params)
    phi, w, tau, u = sp.symbols("phi phi_dot tau u", real=True)
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
    return definition_dict(s, params, states=states, input=u, rhs=rhs, output=phi,
                           region=region)


__all__ = ["trms_yaw"]
