"""The sampled closed loop linearized at its equilibrium: eigenvalues and a linearized eps*.

:func:`sampled_linearization` differentiates the *same* CasADi sample function that
:func:`fl_design.simulate` and :func:`fl_design.sweep` run
(:attr:`fl_design.sim.ClosedLoop.sample`: measurement, design step, RK4 of the plant under
zero-order hold) with respect to the loop state ``X = (x_plant, design_state)``::

    X_(k+1) = F(X_k),   M = dF/dX at the equilibrium X_eq = F(X_eq)

The core (the equilibrium, its tolerance scaled to the state, the simulation fallback, the
decoupled integrator modes) lives in the simulation layer, :mod:`fl_design.sim._loop_jacobian`,
which the adaptive run length of :class:`fl_design.Scenario` also uses; this module adds the
public functions and the scan for a linearized eps*. The reference is the operating point's
output unless given.

Examples
--------
>>> import fl_design as fl
>>> design = fl.presets.pendulum_design()
>>> lin = fl.sampled_linearization(fl.plants.pendulum(), design)
>>> lin.decoupled, lin.spectral_radius < 1, lin.equilibrium_source
(('z',), True, 'newton')
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .. import _validate as V
from .._blas import serial_blas
from ..design import Design
from ..errors import ComputationError, ParameterError
from ..sim import RK4, EpsStar
from ..sim._loop_jacobian import LoopLinearizer, SampledLinearization, fixed_point_tolerance
from ..sim._options import option
from ..sim._run import check_gamma_sign, signed_gammas
from ..sim.kernel._loop import ClosedLoop, resolve_substeps
from ..symbolic import Plant

#: Smallest ``rtol`` of :func:`linearized_eps_star` (4 ulps: float64 resolves no finer).
MIN_RTOL = 4 * float(np.finfo(float).eps)
#: Cap on the bisection steps of :func:`linearized_eps_star` (log2(ln(1e616) / MIN_RTOL) < 62).
MAX_BISECTIONS = 200


def _check(plant, design) -> None:
    V.instance("plant", plant, Plant, "an fl.Plant (fl.Plant.from_ode or fl.plants.*)")
    V.instance("design", design, Design, "an fl.Design(estimator=..., controller=...)")


def _substeps(plant, design, integrator) -> int:
    """RK4 steps per sample of ``integrator`` (an ``fl.RK4`` or None), resolved for the plant."""
    rk4 = option("integrator", integrator, RK4, what="a fl.RK4 (the linearized loop is the "
                 "fixed-step one)")
    return resolve_substeps(plant, design.T, rk4.substeps)


def _reference(plant, r) -> float:
    if r is None:
        return float(plant.casadi().h(plant.x_op))
    return V.real_scalar("r", r)


def sampled_linearization(plant: Plant, design: Design, *, r: float | None = None,
                          integrator: RK4 | None = None) -> SampledLinearization:
    """Jacobian of the closed-loop sample map at its equilibrium, with its eigenvalues.

    The equilibrium ``F(X) = X`` is found by Newton's method from the operating point, to a
    per-component tolerance of a few ulps of the state's scale times the evaluation's
    condition; when Newton does not converge, from the state a simulation at ``r`` settles
    to, polished by Newton (:mod:`fl_design.sim._loop_jacobian`).
    :attr:`SampledLinearization.equilibrium_source` says which, ``residual`` what is left.

    Parameters
    ----------
    plant : Plant
        The plant (relative degree equal to the design's).
    design : Design
        The design (its ``eps``, ``gamma``, gains, ``T``).
    r : float, optional
        Constant reference (default: the output at the plant's operating point).
    integrator : RK4, optional
        The fixed-step integrator between samples, as in :func:`fl_design.simulate`
        (default ``fl.RK4()``: :func:`fl_design.sim.kernel.default_substeps` steps).

    Returns
    -------
    SampledLinearization

    Raises
    ------
    ParameterError
        A plant or design of the wrong type, a non-finite ``r``, a ``gamma`` of the sign
        opposite to ``b``.
    DesignMismatchError
        Relative degrees differ.
    ComputationError
        Neither Newton's method nor a simulation from the operating point gives an equilibrium
        holding the output at ``r`` (the message names ``r``, the residuals and what to try).

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.presets.pendulum_design()
    >>> lin = fl.sampled_linearization(fl.plants.pendulum(), d)
    >>> lin.matrix.shape, lin.state_names[-2:]
    ((7, 7), ('u', 'z'))
    """
    _check(plant, design)
    steps = _substeps(plant, design, integrator)
    check_gamma_sign(plant, design.controller.gamma)
    lin = LoopLinearizer(ClosedLoop(plant, design, substeps=steps))
    return lin(_reference(plant, r), design.parameter_vector())


def linearized_eps_star(plant: Plant, design: Design, *, eps_range=(1e-3, 1.0),
                        gamma: float | None = None,
                        r: float | None = None, integrator: RK4 | None = None, n_scan: int = 48,
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
    integrator : RK4, optional
        The fixed-step integrator between samples (default ``fl.RK4()``).
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
        design = design.replace(gamma=float(signed_gammas(plant, g)))
    check_gamma_sign(plant, design.controller.gamma)
    steps = _substeps(plant, design, integrator)
    lin = LoopLinearizer(ClosedLoop(plant, design, substeps=steps))
    r = _reference(plant, r)
    with serial_blas():  # many 7 x 7 eigenvalue problems: one OpenBLAS thread
        return _scan(lin, r, design, lo, hi, n_scan, rtol)


def _scan(lin, r, design, lo, hi, n_scan, rtol) -> EpsStar:
    """:func:`linearized_eps_star`'s scan and bisection (its docstring)."""

    def stable(eps: float) -> bool:
        return lin(r, _parameters(design, eps)).spectral_radius < 1.0

    grid = np.geomspace(lo, hi, n_scan)
    fast = _rest_radii(lin, r, np.stack([_parameters(design, e) for e in grid], axis=1))

    def scan_stable(i: int) -> bool:  # the batched radius where it applies, else lin itself
        return fast[i] < 1.0 if np.isfinite(fast[i]) else stable(grid[i])

    if not scan_stable(0):
        return EpsStar(math.nan, float(lo))
    bad = next((i for i in range(1, n_scan) if not scan_stable(i)), None)
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


@functools.lru_cache(maxsize=512)
def _estimator_vector(estimator, eps: float) -> np.ndarray:
    v = np.asarray(estimator.replace(eps=eps).parameter_vector(), dtype=float).ravel()
    v.setflags(write=False)
    return v


def _parameters(design: Design, eps: float) -> np.ndarray:
    """``design.replace(eps=eps).parameter_vector()``, the estimator's part computed once per
    ``(estimator, eps)`` (the scan grid is the same for every gamma of a curve)."""
    return np.concatenate([_estimator_vector(design.estimator, float(eps)),
                           [design.controller.gamma]])


def _rest_radii(lin: LoopLinearizer, r: float, ps: np.ndarray) -> np.ndarray:
    """Spectral radius of the linearized loop for each column of ``ps`` where the loop at rest
    at the operating point (:meth:`LoopLinearizer.start`) is already the equilibrium holding
    ``r``, NaN elsewhere.

    There Newton's method of :class:`LoopLinearizer` stops at its first test and
    ``lin(r, p)`` linearizes at that state: here the same CasADi function is evaluated for
    every column in one mapped call (bitwise the same numbers), the same test applied, and
    the radius taken as ``lin`` takes it (decoupled unit columns left out).
    """
    X = lin.start()
    n, N = X.size, ps.shape[1]
    out = np.full(N, np.nan)
    if not lin._holds(X, r):
        return out
    F, J = (np.asarray(v, dtype=float) for v in lin.F.map(N)(
        np.tile(X[:, None], (1, N)), np.full((1, N), float(r)), ps))
    eye = np.eye(n)
    for k in range(N):
        M, G = J[:, k * n:(k + 1) * n], F[:, k] - X
        if not (np.all(np.isfinite(G)) and np.all(np.abs(G) <= fixed_point_tolerance(X, M))):
            continue
        keep = [j for j in range(n) if np.max(np.abs(M[:, j] - eye[:, j])) != 0.0]
        eig = np.linalg.eigvals(M[np.ix_(keep, keep)]) if keep else np.zeros(0)
        out[k] = float(np.max(np.abs(eig))) if eig.size else 0.0
    return out


__all__ = ["SampledLinearization", "linearized_eps_star", "sampled_linearization"]
