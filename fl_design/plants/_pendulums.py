"""Pendulums: the torque-driven damped pendulum and the pendulum on a cart (crane or inverted)."""

from __future__ import annotations

import math

from .. import _validate as V
from ..symbolic._plant import Plant
from ._common import definition_dict, library_plant, param_symbols, validated_params


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
        Relative degree 2, constant input coefficient ``b``.

    Examples
    --------
    >>> import fl_design as fl
    >>> p = fl.plants.pendulum(c=0.1)
    >>> p.relative_degree(), p.b_bounds()
    (2, (1.0, 1.0))
    """
    vals = validated_params({"g": g, "l": l, "b": b}, {"c": c})
    return library_plant(pendulum_definition, params=vals, name="pendulum",
                         input_range=input_range)


def pendulum_definition(params: dict) -> dict:
    """``theta'' = -(g/l) sin(theta) - c theta' + b u`` in SymPy (:func:`pendulum`'s definition).

    ``params`` as :func:`pendulum` validated them; the dict returned is described by
    :func:`~fl_design.plants._common.definition_dict`.

    Examples
    --------
    >>> from fl_design.plants._pendulums import pendulum_definition
    >>> pendulum_definition({"g": 9.81, "l": 1.0, "b": 1.0, "c": 0.5})["rhs"][1]
    b*u - c*theta_dot - g*sin(theta)/l
    """
    import sympy as sp

    s = param_symbols(params)
    th, om, u = sp.symbols("theta theta_dot u", real=True)
    rhs = [om, -(s["g"] / s["l"]) * sp.sin(th) - s["c"] * om + s["b"] * u]
    return definition_dict(s, params, states=[th, om], input=u, rhs=rhs, output=th,
                           region={th: (-math.pi, math.pi), om: (-10.0, 10.0)})




def cart_pendulum(inverted: bool = False, *, M: float = 1.0, m: float = 0.2, l: float = 0.3,
                  J: float = 6e-3, c: float = 2.0, gamma_p: float = 0.1, g: float = 9.81,
                  input_range=(-10.0, 10.0)) -> Plant:
    """A pendulum on a cart (a lab gantry crane by default), output the cart position.

    Model: the *balance system* of K. J. Astrom and R. M. Murray, *Feedback Systems*, 2nd ed.,
    Princeton University Press, 2021, Sec. 3.1 (Example 2.1 in the 1st ed., eq. (2.9)), with
    ``vartheta`` the angle from the upright vertical::

        (M + m) p'' - m l cos(vartheta) vartheta'' + c p' + m l sin(vartheta) vartheta'^2 = F
        -m l cos(vartheta) p'' + (J + m l^2) vartheta'' + gamma_p vartheta' - m g l sin(vartheta) = 0

    Here ``theta`` is measured from the pendulum's rest direction: ``vartheta = theta`` when
    ``inverted=True`` (balanced upright), ``vartheta = theta + pi`` by default (hanging below the
    cart, a gantry crane). With ``s = +1`` (inverted) or ``-1`` (hanging), ``cos vartheta =
    s cos theta`` and ``sin vartheta = s sin theta``.

    * states ``(p, p_dot, theta, theta_dot)``; input ``F`` (force on the cart, N) in
      ``[-10, 10]``; output ``y = p`` (cart position, m): relative degree 2, ``n - rho = 2``;
    * input coefficient, from the 2 x 2 mass matrix: ``b(theta) = J_t / ((M + m) J_t - m^2 l^2
      cos^2 theta)`` with ``J_t = J + m l^2``; largest at ``theta = 0``, smallest at the
      region's largest ``|theta|``. Default values: ``b in [0.9109, 0.9524]`` 1/kg
      (``|theta| <= 0.6``); it does not depend on ``s``;
    * zero dynamics (cart held, ``p = p' = p'' = 0``): the pendulum alone, ``J_t theta'' +
      gamma_p theta' - s m g l sin(theta) = 0``, linearized ``J_t lambda^2 + gamma_p lambda -
      s m g l = 0``. Hanging: a damped pendulum, minimum phase (default: ``lambda = -2.08 +-
      4.49j``, the sway decays as ``exp(-2.08 t)``: to 2 % in 1.9 s); inverted: one real
      positive zero-dynamics eigenvalue (``+3.29`` by default, with ``-7.46``), **not minimum phase**: the
      method does not apply (:func:`fl_design.simulate` warns, naming the eigenvalue);
    * region: ``p in [-0.5, 0.5]`` m, ``p_dot in [-2, 2]`` m/s, ``theta in [-0.6, 0.6]`` rad,
      ``theta_dot in [-5, 5]`` rad/s.

    Default parameters: a bench-top gantry crane (cart 1 kg on a 1 m track, a 0.2 kg rod of
    0.6 m hung at its end, so ``l = 0.3`` m and ``J = m (2l)^2 / 12 = 6e-3`` kg m^2), viscous
    cart friction ``c = 2`` N s/m and pivot damping ``gamma_p = 0.1`` N m s (chosen so the sway
    decays within 2 s).

    Parameters
    ----------
    inverted : bool, optional
        Balance the pendulum upright (non-minimum phase) instead of hanging (default False).
    M : float, optional
        Cart mass, 1 kg.
    m : float, optional
        Pendulum mass, 0.2 kg.
    l : float, optional
        Distance from the pivot to the pendulum's centre of mass, 0.3 m.
    J : float, optional
        Pendulum inertia about its centre of mass, 6e-3 kg m^2.
    c : float, optional
        Cart viscous friction, 2 N s/m (>= 0).
    gamma_p : float, optional
        Pivot viscous damping, 0.1 N m s (>= 0; 0 leaves the hanging zero dynamics undamped,
        marginal, and so not minimum phase by the linear test).
    g : float, optional
        Gravity, 9.81 m/s^2.
    input_range : (lo, hi), optional
        Admissible forces (default ``(-10, 10)`` N).

    Returns
    -------
    Plant
        Relative degree 2 in the cart position; minimum phase hanging, not when inverted.

    Examples
    --------
    >>> import fl_design as fl
    >>> crane = fl.plants.cart_pendulum()
    >>> nf = crane.normal_form()
    >>> crane.relative_degree(), nf.minimum_phase, nf.zero_dynamics_eigenvalues.round(2).tolist()
    (2, True, [(-2.08-4.49j), (-2.08+4.49j)])
    >>> fl.plants.cart_pendulum(inverted=True).normal_form().minimum_phase
    False
    """
    inverted = V.boolean("inverted", inverted)
    vals = validated_params({"M": M, "m": m, "l": l, "J": J, "g": g}, {"c": c, "gamma_p": gamma_p})
    return library_plant(cart_pendulum_definition, params=vals, input_range=input_range,
                         name="cart_pendulum_inverted" if inverted else "cart_pendulum",
                         inverted=inverted)


def cart_pendulum_definition(params: dict, *, inverted: bool) -> dict:
    """The SymPy definition of :func:`cart_pendulum` from its validated ``params``.

    ``inverted`` balances the pendulum upright. The contract of a definition:
    :func:`~fl_design.plants._common.definition_dict`.

    Examples
    --------
    >>> from fl_design.plants._pendulums import cart_pendulum_definition
    >>> crane = cart_pendulum_definition(dict(fl.plants.cart_pendulum()._recipe.params),
    ...                                  inverted=False)
    >>> crane["states"], crane["output"]
    ([p, p_dot, theta, theta_dot], p)
    """
    import sympy as sp

    s = param_symbols(params)
    p, v, th, om, F = sp.symbols("p p_dot theta theta_dot F", real=True)
    sgn = 1 if inverted else -1
    ml, Jt = s["m"] * s["l"], s["J"] + s["m"] * s["l"] ** 2
    cos = sgn * ml * sp.cos(th)  # the off-diagonal of the mass matrix, negated
    f_cart = F - s["c"] * v - sgn * ml * sp.sin(th) * om ** 2
    f_pend = sgn * s["m"] * s["g"] * s["l"] * sp.sin(th) - s["gamma_p"] * om
    det = (s["M"] + s["m"]) * Jt - cos ** 2  # > 0: (M + m) J_t > m^2 l^2 since J_t > m l^2
    acc_p = (Jt * f_cart + cos * f_pend) / det  # Cramer's rule on the 2 x 2 mass matrix
    acc_th = (cos * f_cart + (s["M"] + s["m"]) * f_pend) / det
    return definition_dict(s, params, states=[p, v, th, om], input=F,
                           rhs=[v, acc_p, om, acc_th], output=p,
                           region={p: (-0.5, 0.5), v: (-2.0, 2.0), th: (-0.6, 0.6),
                                   om: (-5.0, 5.0)})


__all__ = ["cart_pendulum", "pendulum"]
