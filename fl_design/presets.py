"""The paper's designs, defined once: the TRMS yaw EHGO design and the least-squares baselines.

Shenoy, Saradagi, Pasumarthy and Chellaboina control the yaw of a Twin Rotor MIMO System
(TRMS) at ``T = 1 ms`` with an EHGO of polynomial ``s^3 + 6 s^2 + 11 s + 6`` (roots -1, -2,
-3), ``eps = 0.05``, the dynamic controller ``K = (2, 4)``, ``gamma = 3e-4``, ``k_I = 1e-3``,
the velocity estimate clamped to ``|xhat_2| <= 0.05`` and the input to ``[-2.5, 2.5]``; they
compare against the least-squares estimator of Fraile, Marchi and Tabuada with windows of 9
and 26 samples under the same controller. The demo, the tests, ``verify/`` and ``examples/``
all take the designs from here.

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

from .design import EHGO, Design, DynamicController, LeastSquaresEstimator

#: Sampling time of the paper's experiments (s).
T_PAPER = 1e-3
#: The paper's observer polynomial coefficients (roots -1, -2, -3).
PAPER_COEFFS = (6.0, 11.0, 6.0)
#: Reference step of the paper's TRMS experiment (rad).
PAPER_STEP = 0.3
#: The least-squares windows the paper compares.
PAPER_WINDOWS = (9, 26)
_DEFAULT_U_LIMITS = (-2.5, 2.5)


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
    eps : float, optional
        Observer time constant (default 0.02).
    gamma : float, optional
        Controller gain (default 1e-2).
    **controller
        More :class:`~fl_design.DynamicController` options (``ki``, ``u_limits``, ...).

    Returns
    -------
    Design

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.presets.pendulum_design()
    >>> fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 20.0)).status
    'converged'
    """
    return Design(estimator=EHGO(rho=2, eps=eps, T=T_PAPER),
                  controller=DynamicController((2.0, 4.0), gamma, **controller))


__all__ = ["PAPER_COEFFS", "PAPER_STEP", "PAPER_WINDOWS", "T_PAPER", "least_squares_design",
           "paper_controller", "paper_design", "pendulum_design"]
