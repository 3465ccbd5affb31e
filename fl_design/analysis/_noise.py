"""Noise gain of the sampled closed loop: the input's standard deviation per unit sensor noise.

The loop linearized at its equilibrium (the *same* sample map that :func:`fl_design.simulate`
runs, :class:`fl_design.sim.ClosedLoop`), with the measurement noise ``w_k`` as its input::

    X_(k+1) = M X_k + G w_k,     u_k = C X_k + D w_k

For white noise of unit variance the stationary covariance ``W`` of ``X`` solves the discrete
Lyapunov equation ``W = M W M^T + G G^T`` (:func:`scipy.linalg.solve_discrete_lyapunov`) and
the input's variance is ``C W C^T + D^2``: :func:`noise_gain` returns its square root, so that
a sensor with noise of standard deviation ``s`` per sample moves ``u`` by ``noise_gain * s``
(rms, in steady state). States that only integrate themselves and feed nothing (the
integrator ``z`` when ``k_I = 0``) are left out. An unstable loop has no stationary variance:
the gain is ``inf``.

Examples
--------
>>> import fl_design as fl
>>> g = fl.analysis.noise_gain(fl.plants.pendulum(), fl.presets.pendulum_design())
>>> 0 < g < float("inf")
True
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import scipy.linalg

from .. import _validate as V
from ..design import Design
from ..sim._loop_jacobian import LoopLinearizer
from ..sim.kernel._loop import ClosedLoop, resolve_substeps
from ..symbolic import Plant


def noise_gain(plant: Plant, design: Design, *, r: float | None = None,
               substeps: int | None = None) -> float:
    """Steady-state rms of ``u`` per unit rms of white measurement noise (module docstring).

    Parameters
    ----------
    plant : Plant
        The plant.
    design : Design
        The design.
    r : float, optional
        Constant reference of the equilibrium (default the operating point's output).
    substeps : int, optional
        RK4 steps per sample (as in :func:`fl_design.simulate`).

    Returns
    -------
    float
        ``sqrt(C W C^T + D^2)``; ``inf`` when the linearized loop is not Schur.

    Raises
    ------
    ParameterError
        A plant or design of the wrong type.
    ComputationError
        No equilibrium of the loop (see :func:`fl_design.sampled_linearization`).

    Examples
    --------
    >>> import fl_design as fl
    >>> plant = fl.plants.trms_yaw()
    >>> wide = fl.analysis.noise_gain(plant, fl.presets.paper_design(eps=0.1))
    >>> narrow = fl.analysis.noise_gain(plant, fl.presets.paper_design(eps=0.05))
    >>> bool(wide < narrow)  # a slower observer amplifies noise less
    True
    """
    V.instance("plant", plant, Plant, "an fl.Plant (fl.Plant.from_ode or fl.plants.*)")
    V.instance("design", design, Design, "an fl.Design(estimator=..., controller=...)")
    loop = ClosedLoop(plant, design, substeps=resolve_substeps(plant, design.T, substeps))
    r = float(plant.casadi().h(plant.x_op)) if r is None else V.real_scalar("r", r)
    p = design.parameter_vector()
    lin = LoopLinearizer(loop)(r, p)
    if not lin.spectral_radius < 1.0:
        return math.inf
    x, s, w = ca.SX.sym("x", loop.n), ca.SX.sym("s", loop.m), ca.SX.sym("w")
    x_next, s_next, u = loop.sample(x, s, r, w, 0.0, p)[:3]
    X, F = ca.vertcat(x, s), ca.vertcat(x_next, s_next)
    fun = ca.Function("fl_noise", [X, w], [ca.jacobian(F, X), ca.jacobian(F, w),
                                            ca.jacobian(u, X), ca.jacobian(u, w)])
    M, G, C, D = (np.asarray(a, dtype=float) for a in fun(np.concatenate([lin.x_eq, lin.s_eq]),
                                                            0.0))
    return stationary_std(M, G, C, D)


def stationary_std(M, G, C, D) -> float:
    """Stationary standard deviation of ``u = C X + D w`` for ``X' = M X + G w``, unit white w.

    States that only integrate themselves and feed nothing (column ``j`` of ``M`` the unit
    vector, ``C[0, j] = 0``) are left out first; ``M`` must then be Schur.

    Parameters
    ----------
    M, G, C, D : numpy.ndarray
        ``(n, n)``, ``(n, 1)``, ``(1, n)`` and ``(1, 1)``: the linearized loop from the noise.

    Returns
    -------
    float
        ``sqrt(C W C^T + D^2)`` with ``W = M W M^T + G G^T``.

    Examples
    --------
    >>> import numpy as np
    >>> a = 0.5  # x' = a x + w, u = x: variance 1 / (1 - a^2)
    >>> round(stationary_std(np.array([[a]]), np.ones((1, 1)), np.ones((1, 1)),
    ...                      np.zeros((1, 1))) ** 2, 12)
    1.333333333333
    """
    eye = np.eye(M.shape[0])
    keep = [j for j in range(M.shape[0])
            if not (np.array_equal(M[:, j], eye[:, j]) and C[0, j] == 0.0)]
    M, G, C = M[np.ix_(keep, keep)], G[keep], C[:, keep]
    W = scipy.linalg.solve_discrete_lyapunov(M, G @ G.T, method="bilinear")
    return float(math.sqrt(max(0.0, float((C @ W @ C.T)[0, 0] + D[0, 0] ** 2))))


__all__ = ["noise_gain", "stationary_std"]
