"""The paper's designs, defined once: the TRMS yaw EHGO design and the least-squares baselines.

Shenoy, Saradagi, Pasumarthy and Chellaboina control the yaw of a Twin Rotor MIMO System
(TRMS) at ``T = 1 ms`` with an EHGO of polynomial ``s^3 + 6 s^2 + 11 s + 6`` (roots -1, -2,
-3), ``eps = 0.05``, the dynamic controller ``K = (2, 4)``, ``gamma = 3e-4``, ``k_I = 1e-3``,
the velocity estimate clamped to ``|xhat_2| <= 0.05`` and the input to ``[-2.5, 2.5]``; they
compare against the least-squares estimator of Fraile, Marchi and Tabuada with windows of 9
and 26 samples under the same controller. The demo, the tests, ``verify/`` and ``examples/``
all take the designs from here, and so do the bench designs of the other library plants
(:mod:`fl_design.plants`): one per plant, each converging from its operating point after a
small step at ``T = 1 ms`` (``tests/symbolic/test_library_loops.py``).

Examples
--------
>>> from fl_design import presets
>>> d = presets.paper_design()
>>> d.estimator.eps, d.controller.gamma, d.controller.u_range
(0.05, 0.0003, (-2.5, 2.5))
>>> presets.least_squares_design(26).estimator.window
26
"""

from __future__ import annotations

from .design import EHGO, Design, DynamicController, LeastSquaresEstimator, gains_from_poles

#: Sampling time of the paper's experiments (s).
T_PAPER = 1e-3
#: The paper's observer polynomial coefficients (roots -1, -2, -3).
PAPER_COEFFS = (6.0, 11.0, 6.0)
#: Reference step of the paper's TRMS experiment (rad).
PAPER_STEP = 0.3
#: The least-squares windows the paper compares.
PAPER_WINDOWS = (9, 26)
_DEFAULT_U_LIMITS = (-2.5, 2.5)


def _ehgo_bench(rho: int, gains, eps: float, gamma: float, controller: dict,
                u_limits=None) -> Design:
    """EHGO of order ``rho + 1`` with all poles at ``-1/eps`` at ``T = 1 ms`` and the dynamic
    controller ``gains``; ``u_limits`` unless ``controller`` sets its own."""
    controller.setdefault("u_limits", u_limits)
    return Design(estimator=EHGO(rho=rho, eps=eps, T=T_PAPER),
                  controller=DynamicController(gains, gamma, **controller))


def paper_controller(gamma: float = 3e-4, *, u_limits=_DEFAULT_U_LIMITS) -> DynamicController:
    """The paper's TRMS controller: ``K = (2, 4)``, ``k_I = 1e-3``, ``|xhat_2| <= 0.05``.

    Parameters
    ----------
    gamma : float, optional
        Controller gain (the paper's ``3e-4`` by default).
    u_limits : (float, float) or None, optional
        Input saturation, default ``(-2.5, 2.5)`` (the TRMS input range); None removes it.

    Returns
    -------
    DynamicController
        The gains ``(2, 4)``, ``gamma``, the integrator and the estimate limits.

    Examples
    --------
    >>> from fl_design.presets import paper_controller
    >>> paper_controller().estimate_ranges[1]
    (-0.05, 0.05)
    """
    return DynamicController(gains=(2.0, 4.0), gamma=gamma, ki=1e-3, u_limits=u_limits,
                             estimate_limits=(None, 0.05))


def paper_design(eps: float = 0.05, gamma: float = 3e-4, *, u_limits=_DEFAULT_U_LIMITS,
                 method: str = "bilinear") -> Design:
    """The paper's TRMS design: EHGO ``s^3 + 6 s^2 + 11 s + 6`` at ``T = 1 ms`` + its controller.

    Parameters
    ----------
    eps : float, optional
        Observer time constant (the paper's 0.05 by default).
    gamma : float, optional
        Controller gain (the paper's 3e-4 by default).
    u_limits : (float, float) or None, optional
        Input saturation, default ``(-2.5, 2.5)``; None removes it.
    method : str, optional
        EHGO discretization (default the paper's bilinear one).

    Returns
    -------
    Design
        EHGO and :func:`paper_controller`, both at ``T = 1 ms``.

    Examples
    --------
    >>> from fl_design.presets import paper_design
    >>> paper_design(0.1).estimator.alpha
    0.01
    """
    obs = EHGO(rho=2, eps=eps, T=T_PAPER, coeffs=PAPER_COEFFS, method=method)
    return Design(estimator=obs, controller=paper_controller(gamma, u_limits=u_limits))


def least_squares_design(window: int, gamma: float = 3e-4, *,
                         u_limits=_DEFAULT_U_LIMITS) -> Design:
    """The least-squares baseline under the paper's controller (the paper uses 9 and 26).

    Parameters
    ----------
    window : int
        Number of samples in the least-squares fit.
    gamma : float, optional
        Controller gain (the paper's 3e-4 by default).
    u_limits : (float, float) or None, optional
        Input saturation, default ``(-2.5, 2.5)``; None removes it.

    Returns
    -------
    Design
        Least-squares estimator of ``window`` samples and :func:`paper_controller`.

    Examples
    --------
    >>> from fl_design.presets import least_squares_design
    >>> least_squares_design(9).estimator.flops_per_step
    27
    """
    return Design(estimator=LeastSquaresEstimator(rho=2, T=T_PAPER, window=window),
                  controller=paper_controller(gamma, u_limits=u_limits))


def pendulum_design(eps: float = 0.02, gamma: float = 1e-2, **controller) -> Design:
    """A small bench design for the library's damped pendulum (examples and tests).

    EHGO with all observer poles at ``-1/eps`` (binomial coefficients), ``T = 1 ms``, and the
    dynamic controller ``K = (2, 4)`` (closed-loop polynomial ``s^2 + 4 s + 2``), no limits.

    Parameters
    ----------
    eps, gamma : float, optional
        Observer time constant and controller gain (defaults 0.02 and 1e-2).
    **controller
        More :class:`~fl_design.DynamicController` options (``ki``, ``u_limits``, ...).

    Returns
    -------
    Design
        EHGO of order 3 and the dynamic controller, ``T = 1 ms``.

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.presets.pendulum_design()
    >>> fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 20.0)).status
    'converged'
    """
    return _ehgo_bench(2, (2.0, 4.0), eps, gamma, controller)


def trms_lag_design(eps: float = 0.05, gamma: float = 3e-3, **controller) -> Design:
    """A relative-degree-3 bench design for the TRMS yaw with its motor lag (``trms_yaw(True)``).

    EHGO of order 4 with all poles at ``-1/eps``, ``T = 1 ms``; gains placing the closed loop at
    ``-1, -2, -3`` (``K = (6, 11, 6)``), input limited to the TRMS range ``[-2.5, 2.5]``.
    ``gamma = 3e-3`` (10x the paper's): at rest the loop's slowest linear time constant is
    about ``0.057 / gamma`` (188 s at the paper's 3e-4, 19 s here; sampled linearization),
    because the smoothed Coulomb friction makes the plant near rest a heavily damped one.
    Measured: a 0.05 rad step converges (2 % band) after 19.3 s, overshoot 3.9 %; empirical
    eps* 0.088, while the linearized loop is stable up to eps = 1 (see
    :func:`fl_design.plants.trms_yaw` for why).

    Parameters
    ----------
    eps, gamma : float, optional
        Observer time constant and controller gain (defaults 0.05 and 3e-3;
        ``b`` in ``[3.6, 6.8]``).
    **controller
        More :class:`~fl_design.DynamicController` options (``ki``, ``u_limits``, ...).

    Returns
    -------
    Design
        Gains ``(6, 11, 6)`` on a fourth-order EHGO; the TRMS's input range.

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.presets.trms_lag_design()
    >>> d.rho, d.controller.gains
    (3, (6.0, 11.0, 6.0))
    """
    return _ehgo_bench(3, gains_from_poles([-1, -2, -3]), eps, gamma, controller,
                       _DEFAULT_U_LIMITS)


def flexible_joint_design(eps: float = 5e-3, gamma: float = 3e-5, **controller) -> Design:
    """A relative-degree-4 bench design for the flexible-joint robot (``flexible_joint()``).

    EHGO of order 5 with all poles at ``-1/eps``, ``T = 1 ms``; closed loop ``(s + 5)^4``
    (``K = (625, 500, 150, 20)``); input limited to ``[-10, 10]``. ``b = 418.5``, so ``gamma``
    must stay far below ``1 / b = 2.4e-3``: ``3e-5`` gives ``gamma b = 0.013`` per sample.
    Measured: a 0.05 rad step converges after 2.7 s without overshoot; eps* 0.0131 (empirical)
    and 0.0127 (linearized).

    Parameters
    ----------
    eps, gamma : float, optional
        Observer time constant and controller gain (defaults 5e-3 and 3e-5).
    **controller
        More :class:`~fl_design.DynamicController` options (``ki``, ``u_limits``, ...).

    Returns
    -------
    Design
        Closed loop ``(s + 5)^4``, EHGO of order 5, ``|u| <= 10``.

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.presets.flexible_joint_design().controller.gains
    (625.0, 500.0, 150.0, 20.0)
    """
    return _ehgo_bench(4, gains_from_poles([-5] * 4), eps, gamma, controller, (-10.0, 10.0))


def cart_pendulum_design(eps: float = 5e-3, gamma: float = 0.05, **controller) -> Design:
    """A relative-degree-2 bench design for the gantry crane (``cart_pendulum()``, output the cart).

    EHGO of order 3 with all poles at ``-1/eps``, ``T = 1 ms``; closed loop ``(s + 2)^2``
    (``K = (4, 4)``) on the cart position; the force limited to ``[-10, 10]`` N. The sway (zero
    dynamics, decaying as ``exp(-2.08 t)``) is not controlled, only excited. Measured: a 5 cm
    step converges after 2.9 s with negligible overshoot; eps* 0.0153 (empirical) and 0.0152
    (linearized).

    Parameters
    ----------
    eps, gamma : float, optional
        Observer time constant and controller gain (defaults 5e-3 and 0.05;
        ``b`` in ``[0.91, 0.95]`` 1/kg).
    **controller
        More :class:`~fl_design.DynamicController` options (``ki``, ``u_limits``, ...).

    Returns
    -------
    Design
        EHGO of order 3 and the dynamic controller for the crane.

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.presets.cart_pendulum_design().controller.gains
    (4.0, 4.0)
    """
    return _ehgo_bench(2, gains_from_poles([-2, -2]), eps, gamma, controller, (-10.0, 10.0))


def maglev_design(eps: float = 2e-3, gamma: float = -1.6e-3, **controller) -> Design:
    """A relative-degree-3 bench design for the magnetic levitation (``maglev()``), ``gamma < 0``.

    ``b < 0`` on the maglev's region, so ``gamma`` is negative (the opposite sign is refused).
    EHGO of order 4 with all poles at ``-1/eps``, ``T = 1 ms``; closed loop ``(s + 40)^3``
    (``K = (64000, 4800, 120)``); coil voltage limited to ``[0, 24]`` V. The plant is fast for
    1 ms sampling (open-loop pole ``+57`` rad/s): the loop needs ``|gamma| b`` large enough to
    beat it and a small ``eps``. Measured with ``fl.sweep`` (0.2 mm step from the 6 mm gap,
    3 s runs, eps in [1.5, 3.2] ms): every run converges for ``|gamma|`` in ``[1e-3, 2e-3]``
    only up to an eps* between 2 and 2.9 ms, and ``|gamma| <= 5.8e-4`` fails at every eps
    >= 1.4 ms; at the former ``gamma = -1e-3`` the run at ``eps = 1.99`` ms already
    oscillates, at ``-1.6e-3`` every eps from 1.5 to 2.41 ms converges (linearized eps*
    2.25 ms), so ``eps = 2`` ms sits inside the stable window. Measured: the step converges
    (to 4 um) after 0.11 s, overshoot 0.34 %.

    Parameters
    ----------
    eps, gamma : float, optional
        Observer time constant and controller gain (defaults 2e-3 and -1.6e-3;
        ``b`` in ``[-174.6, -18.2]``).
    **controller
        More :class:`~fl_design.DynamicController` options (``ki``, ``u_limits``, ...).

    Returns
    -------
    Design
        EHGO of order 4 and the dynamic controller (negative ``gamma``).

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.presets.maglev_design()
    >>> resp = fl.simulate(fl.plants.maglev(), d, fl.Scenario(6.2e-3, 2.0))
    >>> resp.status
    'converged'
    """
    return _ehgo_bench(3, gains_from_poles([-40] * 3), eps, gamma, controller, (0.0, 24.0))


#: The bench step of each library plant (config name -> reference, absolute output value): a
#: small step from the plant's operating point (its output there: 0 except the maglev's 6 mm).
BENCH_REFERENCES = {"trms": PAPER_STEP, "trms-lag": 0.05, "pendulum": 0.1,
                    "flexible-joint": 0.05, "cart-pendulum": 0.05, "maglev": 6.2e-3}


def bench_design(name: str) -> Design:
    """The bench design of a library plant by its config name (``fl-design --plant NAME``).

    Parameters
    ----------
    name : str
        One of ``trms``, ``trms-lag``, ``pendulum``, ``flexible-joint``, ``cart-pendulum``,
        ``maglev`` (the keys of :data:`BENCH_REFERENCES`).

    Returns
    -------
    Design
        That plant's ``*_design()`` with its defaults.

    Raises
    ------
    ParameterError
        An unknown name (the message lists the valid ones).

    Examples
    --------
    >>> from fl_design.presets import bench_design
    >>> bench_design("maglev").controller.gamma
    -0.0016
    >>> bench_design("trms").estimator.eps
    0.05
    """
    from .errors import ParameterError

    factories = {"trms": paper_design, "trms-lag": trms_lag_design, "pendulum": pendulum_design,
                 "flexible-joint": flexible_joint_design,
                 "cart-pendulum": cart_pendulum_design, "maglev": maglev_design}
    if name not in factories:
        raise ParameterError(f"no bench design for {name!r}; library plants: "
                             f"{', '.join(factories)}")
    return factories[name]()


__all__ = ["BENCH_REFERENCES", "PAPER_COEFFS", "PAPER_STEP", "PAPER_WINDOWS", "T_PAPER",
           "bench_design", "cart_pendulum_design", "flexible_joint_design",
           "least_squares_design", "maglev_design", "paper_controller", "paper_design",
           "pendulum_design", "trms_lag_design"]
