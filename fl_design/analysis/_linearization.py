"""The sampled closed loop linearized at its equilibrium: eigenvalues and a linearized eps*.

:func:`sampled_linearization` differentiates the *same* CasADi sample function that
:func:`fl_design.simulate` and :func:`fl_design.sweep` run
(:attr:`fl_design.sim.ClosedLoop.sample`: measurement, design step, RK4 of the plant
under zero-order hold) with respect to the loop state ``X = (x_plant, design_state)``::

    X_(k+1) = F(X_k),   M = dF/dX at the equilibrium X_eq = F(X_eq)

The equilibrium is found by Newton's method on ``F(X) - X = 0`` (least-squares steps, so that
directions in which every point is an equilibrium are left alone), started at the plant's
operating point with ``u = u_eq``; the reference is the operating point's output unless given.

**Decoupled modes.** With ``ki = 0`` the controller's integrator ``z_k = z_(k-1) + T e_k`` is
still a state of the design, but nothing depends on it: its column of ``M`` is the unit vector,
i.e. an eigenvalue exactly 1 that says nothing about stability. Such states (column of ``M``
equal to the unit vector) are reported in ``decoupled`` and removed before the spectral radius
is computed; the remaining eigenvalues are those of the loop. (The dynamic law ``u_k = u_(k-1) +
gamma (v_k - sigmahat_k)`` also *looks* like an integrator, but ``sigmahat`` feeds ``u`` back:
that mode is coupled and stays in the spectrum.)

Examples
--------
>>> import fl_design as fl
>>> design = fl.presets.pendulum_design()
>>> lin = fl.sampled_linearization(fl.plants.pendulum(), design)
>>> lin.decoupled, lin.spectral_radius < 1
(('z',), True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .. import _validate as V
from ..design import Design
from ..errors import ComputationError, ParameterError
from ..sim import EpsStar
from ..sim._closed_loop import ClosedLoop, default_substeps
from ..sim._run import b_sign, check_gamma_sign
from ..symbolic import Plant


@dataclass(frozen=True)
class SampledLinearization:
    """The sampled closed loop linearized at an equilibrium.

    Parameters
    ----------
    matrix : numpy.ndarray
        ``M = dF/dX`` (``(n + m, n + m)``), loop state ``X = (x_plant, design_state)``.
    state_names : tuple of str
        Names of the entries of ``X`` (plant states, ``xi_i``, ``u``, ``z``).
    x_eq, s_eq : numpy.ndarray
        Equilibrium plant and design states.
    r : float
        Reference of the equilibrium.
    decoupled : tuple of str
        States removed as decoupled accumulators (eigenvalue exactly 1, see module docstring).
    eigenvalues : numpy.ndarray
        Eigenvalues of ``M`` without the decoupled states, by decreasing modulus.
    spectral_radius : float
        Largest modulus of ``eigenvalues``.

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
    ...               controller=fl.DynamicController((2, 4), 1e-2, ki=0.5))
    >>> lin = fl.sampled_linearization(fl.plants.pendulum(), d)
    >>> lin.decoupled, lin.eigenvalues.size
    ((), 7)
    """

    matrix: np.ndarray
    state_names: tuple
    x_eq: np.ndarray
    s_eq: np.ndarray
    r: float
    decoupled: tuple
    eigenvalues: np.ndarray
    spectral_radius: float

    @property
    def stable(self) -> bool:
        """True when the spectral radius (decoupled modes removed) is < 1."""
        return bool(self.spectral_radius < 1.0)

    def to_dict(self) -> dict:
        """Plain numbers and lists (eigenvalues as ``[re, im]`` pairs), ready for JSON.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.presets.pendulum_design()
        >>> sorted(fl.sampled_linearization(fl.plants.pendulum(), d).to_dict())[:3]
        ['decoupled', 'eigenvalues', 'matrix']
        """
        return {
            "matrix": self.matrix.tolist(), "state_names": list(self.state_names),
            "x_eq": self.x_eq.tolist(), "s_eq": self.s_eq.tolist(), "r": self.r,
            "decoupled": list(self.decoupled),
            "eigenvalues": [[float(z.real), float(z.imag)] for z in self.eigenvalues],
            "spectral_radius": self.spectral_radius,
        }


class _Linearizer:
    """Jacobian and equilibrium of one loop structure; ``p`` (eps, gamma) varies."""

    def __init__(self, loop: ClosedLoop):
        self.loop = loop
        x, s = ca.SX.sym("x", loop.n), ca.SX.sym("s", loop.m)
        r, p = ca.SX.sym("r"), ca.SX.sym("p", loop.n_p)
        x_next, s_next = loop.sample(x, s, r, 0.0, 0.0, p)[:2]
        X, F = ca.vertcat(x, s), ca.vertcat(x_next, s_next)
        self.F = ca.Function("fl_lin_F", [X, r, p], [F, ca.jacobian(F, X)])
        lay = loop.design.state_layout
        names = [str(sym) for sym in loop.plant.states]
        names += [f"xi_{i}" for i in range(lay["estimator"].stop)] + ["u", "z"]
        self.names = tuple(names)

    def equilibrium(self, r: float, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        loop = self.loop
        s0 = loop.design.initial_state()
        s0[loop.design.state_layout["u"]] = loop.plant.u_eq
        X = np.concatenate([loop.plant.x_op, s0])
        scale = 1.0 + np.max(np.abs(X))
        for _ in range(50):
            F, J = (np.asarray(v, dtype=float) for v in self.F(X, r, p))
            G = F.ravel() - X
            if np.max(np.abs(G)) <= 1e-13 * scale:
                return X, J
            X = X + np.linalg.lstsq(J - np.eye(X.size), -G, rcond=1e-12)[0]
        raise ComputationError(
            f"no closed-loop equilibrium found for r={r!r}: Newton's method stopped with "
            f"max|F(X) - X| = {np.max(np.abs(G)):.3g}; use a reference the plant can hold "
            "(default: the output at its operating point)"
        )

    def __call__(self, r: float, p: np.ndarray) -> SampledLinearization:
        X, M = self.equilibrium(r, p)
        n = X.size
        eye = np.eye(n)
        dec = [j for j in range(n) if np.max(np.abs(M[:, j] - eye[:, j])) == 0.0]
        keep = [j for j in range(n) if j not in dec]
        eig = np.linalg.eigvals(M[np.ix_(keep, keep)]) if keep else np.zeros(0, complex)
        eig = eig[np.argsort(-np.abs(eig), kind="stable")]
        return SampledLinearization(
            matrix=M, state_names=self.names, x_eq=X[: self.loop.n],
            s_eq=X[self.loop.n:], r=float(r), decoupled=tuple(self.names[j] for j in dec),
            eigenvalues=eig, spectral_radius=float(np.max(np.abs(eig))) if eig.size else 0.0,
        )


#: Smallest ``rtol`` of :func:`linearized_eps_star` (4 ulps: float64 resolves no finer).
MIN_RTOL = 4 * float(np.finfo(float).eps)
#: Cap on the bisection steps of :func:`linearized_eps_star` (log2(ln(1e616) / MIN_RTOL) < 62).
MAX_BISECTIONS = 200


def _check(plant, design) -> None:
    V.instance("plant", plant, Plant, "an fl.Plant (fl.Plant.from_ode or fl.plants.*)")
    V.instance("design", design, Design, "an fl.Design(estimator=..., controller=...)")


def _reference(plant, r) -> float:
    if r is None:
        return float(plant.casadi().h(plant.x_op))
    return V.real_scalar("r", r)


def sampled_linearization(plant, design, *, r: float | None = None,
                          substeps: int | None = None) -> SampledLinearization:
    """Jacobian of the closed-loop sample map at its equilibrium, with its eigenvalues.

    Parameters
    ----------
    plant : Plant
        The plant (relative degree equal to the design's).
    design : Design
        The design (its ``eps``, ``gamma``, gains, ``T``).
    r : float, optional
        Constant reference (default: the output at the plant's operating point).
    substeps : int, optional
        RK4 steps per sample, as in :func:`fl_design.simulate` (default
        :func:`fl_design.sim.default_substeps`).

    Returns
    -------
    SampledLinearization

    Raises
    ------
    DesignMismatchError
        Relative degrees differ.
    ComputationError
        No equilibrium found.

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.presets.pendulum_design()
    >>> lin = fl.sampled_linearization(fl.plants.pendulum(), d)
    >>> lin.matrix.shape, lin.state_names[-2:]
    ((7, 7), ('u', 'z'))
    """
    _check(plant, design)
    steps = default_substeps(plant, design.T) if substeps is None else substeps
    lin = _Linearizer(ClosedLoop(plant, design, substeps=steps))
    return lin(_reference(plant, r), design.parameter_vector())


def linearized_eps_star(plant, design, *, eps_range=(1e-3, 1.0), gamma: float | None = None,
                        r: float | None = None, substeps: int | None = None, n_scan: int = 48,
                        rtol: float = 1e-6) -> EpsStar:
    """Largest ``eps`` up to which the linearized sampled loop is stable (spectral radius < 1).

    ``eps*`` is the supremum of the ``eps`` in ``eps_range`` such that every ``eps'`` in
    ``[eps_range[0], eps]`` gives a spectral radius < 1: a scan on ``n_scan`` log-spaced points
    finds the first unstable one, then bisection in ``log eps`` narrows the crossing to
    relative width ``rtol``. (A stable window beyond a first unstable ``eps`` is ignored.)
    The result is the final bracket, an :class:`~fl_design.sim.EpsStar` ``lower <= eps* <
    upper`` with the loop stable at ``lower`` and unstable at ``upper``; a boundary outside
    the range is said as such, never as a number: ``> hi`` (``(hi, inf)``, stable on the
    whole scan) or ``< lo`` (``(nan, lo)``, unstable already at ``lo``).

    Parameters
    ----------
    plant : Plant
        The plant.
    design : Design
        The design; its ``eps`` is replaced by the scanned values.
    eps_range : (float, float), optional
        Search interval, ``0 < lo < hi`` (default ``(1e-3, 1)``).
    gamma : float, optional
        Controller gain (default the design's); a positive value is a magnitude taking the
        sign of ``b``, as in :func:`fl_design.estimate_eps_star`.
    r : float, optional
        Reference of the equilibrium (default the operating point's output).
    substeps : int, optional
        RK4 steps per sample.
    n_scan : int, optional
        Scan points (>= 2, default 48).
    rtol : float, optional
        Relative width of the final bracket (default 1e-6; at least :data:`MIN_RTOL`, about
        8.9e-16, what float64 resolves).

    Returns
    -------
    EpsStar
        ``(a, b)``: spectral radius < 1 at ``a``, >= 1 at ``b``, ``b / a - 1 <= rtol`` (or no
        float in between); ``.value`` is ``a``. ``(hi, inf)`` (prints ``> hi``, ``.value`` None)
        when stable on the whole scan; ``(nan, lo)`` (prints ``< lo``) when unstable at ``lo``.

    Raises
    ------
    ParameterError
        A plant or design of the wrong type, a bad ``eps_range``, ``n_scan`` or ``gamma``
        (zero, or of the sign opposite to ``b``), ``rtol < MIN_RTOL``.
    ComputationError
        No equilibrium found, or the bisection cap :data:`MAX_BISECTIONS` reached.

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.presets.pendulum_design()
    >>> eps_star = fl.linearized_eps_star(fl.plants.pendulum(), d, eps_range=(0.01, 2.0))
    >>> 0.01 < eps_star.lower < eps_star.upper <= eps_star.lower * (1 + 1e-6)
    True
    >>> print(fl.linearized_eps_star(fl.plants.pendulum(), d, eps_range=(0.001, 0.01)))
    > 0.01
    """
    _check(plant, design)
    lo, hi = V.interval("eps_range", eps_range, allow_none=False)
    if lo <= 0:
        raise ParameterError(f"eps_range must satisfy 0 < lo < hi, got ({lo}, {hi})")
    n_scan = V.integer("n_scan", n_scan, minimum=2)
    rtol = V.positive("rtol", rtol)
    if rtol < MIN_RTOL:
        raise ParameterError(f"rtol={rtol!r} is below what float64 can resolve: give rtol >= "
                             f"{MIN_RTOL:.3g} (4 units in the last place)")
    if gamma is not None:
        g = V.nonzero("gamma", gamma)
        design = design.replace(gamma=g * b_sign(plant) if g > 0 and b_sign(plant) else g)
    check_gamma_sign(plant, design.controller.gamma)
    steps = default_substeps(plant, design.T) if substeps is None else substeps
    lin = _Linearizer(ClosedLoop(plant, design, substeps=steps))
    r = _reference(plant, r)

    def stable(eps: float) -> bool:
        return lin(r, design.replace(eps=eps).parameter_vector()).spectral_radius < 1.0

    grid = np.geomspace(lo, hi, n_scan)
    if not stable(grid[0]):
        return EpsStar(math.nan, float(lo))
    bad = next((i for i, e in enumerate(grid[1:], 1) if not stable(e)), None)
    if bad is None:
        return EpsStar(float(hi), math.inf)
    a, b = float(grid[bad - 1]), float(grid[bad])
    for _ in range(MAX_BISECTIONS):
        mid = math.sqrt(a * b)
        if b / a - 1.0 <= rtol or not a < mid < b:  # narrow enough, or no float in between
            return EpsStar(a, b)
        a, b = (mid, b) if stable(mid) else (a, mid)
    raise ComputationError(f"linearized_eps_star: no {rtol:g}-narrow bracket after "
                           f"{MAX_BISECTIONS} bisections (last [{a!r}, {b!r}])")


__all__ = ["SampledLinearization", "linearized_eps_star", "sampled_linearization"]
