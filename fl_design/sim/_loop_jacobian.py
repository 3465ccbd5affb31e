"""The sampled closed loop at its equilibrium: the fixed point of the sample map and its Jacobian.

The loop state ``X = (x_plant, design_state)`` advances by the *same* CasADi sample function
that :func:`fl_design.simulate` and :func:`fl_design.sweep` run
(:attr:`fl_design.sim.ClosedLoop.sample`: measurement, design step, RK4 of the plant under
zero-order hold), noise-free, at a constant reference ``r``::

    X_(k+1) = F(X_k),   M = dF/dX at the equilibrium X_eq = F(X_eq)

**Finding the equilibrium.** Newton's method on ``G(X) = F(X) - X = 0`` with least-squares
steps (directions in which every point is an equilibrium, e.g. a decoupled integrator, are left
alone) and a backtracking line search on the scaled residual, started at the plant's
operating point with ``u = u_eq``. When it does not converge within
:data:`NEWTON_ITERATIONS` (a far start, a stiff friction term, a saturated input on the way),
the loop is *simulated* from the operating point at that reference (a step from rest, as
:func:`fl_design.simulate` starts; CasADi's ``fold`` of the sample map in its interpreter, about
4 us per sample) for up to :data:`SETTLE_SAMPLES` samples, and Newton polishes the state
reached after 1, 2, 4, ... chunks of :data:`SETTLE_CHUNK` samples (at most
:data:`POLISH_ITERATIONS` steps each). :attr:`SampledLinearization.equilibrium_source`
says which path gave the equilibrium (``"newton"`` or ``"simulation"``).

**When is ``F(X) = X``?** Per component, ``|G_i(X)| <= tol_i`` with::

    tol_i = TOL_ULPS * u * ((|J| + I) s)_i,   s_j = max(1, |X_j|),   u = 2.2e-16

Why: the float ``X`` closest to the exact fixed point is off by up to ``u/2 |X_j|`` per
component, which moves ``G_i`` by up to ``u/2 ((|J| + I) |X|)_i``; evaluating ``F`` (the
observer, the controller, ``substeps`` RK4 steps) adds rounding errors of the same form (the
forward error of a backward-stable evaluation is bounded by its condition ``|J| |X|`` times a
small multiple of ``u``). ``max(1, |X_j|)`` gives components at zero the absolute floor of one
output unit's ulp. On the library plants (pendulum, TRMS up to ``r = 3``, flexible joint),
``|G_i|`` at the converged point perturbed by 4 ulps stays below ``2.4 u ((|J| + I) s)_i``;
:data:`TOL_ULPS` = 16 leaves a margin of about 6. A tolerance scaled to the state is what
makes Newton stop at every reference: an absolute ``1e-13`` cannot be met by a state of
magnitude ``1e3``.

A fixed point must hold the output at ``r``: ``|h(x) - r| <= sqrt(u) max(1, |r|)``. (Every
fixed point of the unsaturated loop does: there ``sigmahat = 0``, so ``v = 0`` and the
integrator ``z`` stops only at ``y = r``. A fixed point elsewhere has the input or an estimate
clamped at a limit: the loop cannot hold ``r``.)

**Decoupled modes.** With ``ki = 0`` the controller's integrator ``z_k = z_(k-1) + T e_k`` is
still a state of the design, but nothing depends on it: its column of ``M`` is the unit vector,
i.e. an eigenvalue exactly 1 that says nothing about stability. Such states (column of ``M``
equal to the unit vector) are reported in ``decoupled`` and removed before the spectral radius
is computed; the remaining eigenvalues are those of the loop. (The dynamic law ``u_k = u_(k-1) +
gamma (v_k - sigmahat_k)`` also *looks* like an integrator, but ``sigmahat`` feeds ``u`` back:
that mode is coupled and stays in the spectrum.)

Examples
--------
The public entry point is :func:`fl_design.sampled_linearization`:

>>> import fl_design as fl
>>> res = fl.sampled_linearization(fl.plants.pendulum(), fl.presets.pendulum_design())
>>> res.decoupled, res.stable, res.equilibrium_source
(('z',), True, 'newton')
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import ComputationError
from .kernel._loop import ClosedLoop

#: Unit roundoff of float64.
UNIT = float(np.finfo(float).eps)
#: Ulps of the per-component fixed-point tolerance (see the module docstring).
TOL_ULPS = 16.0
#: Newton steps from the operating point before the simulation fallback.
NEWTON_ITERATIONS = 50
#: Newton steps polishing a state reached by simulation.
POLISH_ITERATIONS = 8
#: Halvings of a Newton step tried before the step counts as failed.
LINE_SEARCH_HALVINGS = 12
#: Samples per call of the simulation fallback's folded sample map (Newton polishes after
#: 1, 2, 4, ... chunks).
SETTLE_CHUNK = 4096
#: Largest number of samples the simulation fallback runs (262 s at T = 1 ms, about 1 s).
SETTLE_SAMPLES = 2**18


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
        States removed as decoupled accumulators (eigenvalue exactly 1, see
        :mod:`fl_design.sim._loop_jacobian`).
    eigenvalues : numpy.ndarray
        Eigenvalues of ``M`` without the decoupled states, by decreasing modulus.
    spectral_radius : float
        Largest modulus of ``eigenvalues``.
    T : float
        Sampling time of the loop.
    equilibrium_source : str
        ``"newton"`` (Newton's method from the operating point) or ``"simulation"`` (the
        state a simulation from the operating point settled to, polished by Newton).
    residual : float
        ``max |F(X_eq) - X_eq|`` at the equilibrium (absolute).
    tolerance : numpy.ndarray
        Per-component tolerance ``tol_i`` that ``|F_i(X_eq) - X_eq,i|`` met (module docstring).

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
    ...               controller=fl.DynamicController((2, 4), 1e-2, ki=0.5))
    >>> lin = fl.sampled_linearization(fl.plants.pendulum(), d)
    >>> lin.decoupled, lin.eigenvalues.size, lin.equilibrium_source
    ((), 7, 'newton')
    """

    matrix: np.ndarray
    state_names: tuple
    x_eq: np.ndarray
    s_eq: np.ndarray
    r: float
    decoupled: tuple
    eigenvalues: np.ndarray
    spectral_radius: float
    T: float
    equilibrium_source: str
    residual: float
    tolerance: np.ndarray

    @property
    def stable(self) -> bool:
        """True when the spectral radius (decoupled modes removed) is < 1."""
        return bool(self.spectral_radius < 1.0)

    @property
    def slowest_time_constant(self) -> float:
        """``-T / ln(spectral_radius)`` in seconds: the slowest coupled mode's time constant.

        ``inf`` when the loop is not stable (radius >= 1), 0 when it has no coupled mode or
        every mode dies in one sample (radius 0).
        """
        rho = self.spectral_radius
        if rho >= 1.0:
            return math.inf
        return 0.0 if rho == 0.0 else -self.T / math.log(rho)

    def to_dict(self) -> dict:
        """Plain numbers and lists (eigenvalues as ``[re, im]`` pairs), ready for JSON.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.presets.pendulum_design()
        >>> sorted(fl.sampled_linearization(fl.plants.pendulum(), d).to_dict())[:4]
        ['T', 'decoupled', 'eigenvalues', 'equilibrium_source']
        """
        from .._json import jsonable

        return jsonable({
            "matrix": self.matrix, "state_names": list(self.state_names),
            "x_eq": self.x_eq, "s_eq": self.s_eq, "r": self.r,
            "decoupled": list(self.decoupled),
            "eigenvalues": [[float(z.real), float(z.imag)] for z in self.eigenvalues],
            "spectral_radius": self.spectral_radius, "T": self.T,
            "slowest_time_constant": self.slowest_time_constant,
            "equilibrium_source": self.equilibrium_source, "residual": self.residual,
            "tolerance": self.tolerance,
        })


def fixed_point_tolerance(X: np.ndarray, J: np.ndarray) -> np.ndarray:
    """Per-component tolerance on ``F(X) - X``: ``TOL_ULPS u ((|J| + I) max(1, |X|))``.

    Parameters
    ----------
    X : numpy.ndarray
        ``(N,)`` loop state.
    J : numpy.ndarray
        ``(N, N)`` Jacobian ``dF/dX`` at ``X``.

    Returns
    -------
    numpy.ndarray
        ``(N,)``; see :mod:`fl_design.sim._loop_jacobian` for why.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._loop_jacobian import fixed_point_tolerance
    >>> fixed_point_tolerance(np.array([0.0, 1e3]), np.eye(2)) / 2.220446049250313e-16
    array([   32., 32000.])
    """
    s = np.maximum(1.0, np.abs(X))
    return TOL_ULPS * UNIT * ((np.abs(J) + np.eye(X.size)) @ s)


class LoopLinearizer:
    """Equilibrium and Jacobian of one loop structure; ``p`` (eps, gamma) varies.

    Parameters
    ----------
    loop : ClosedLoop
        Plant, design and integrator.

    Examples
    --------
    The loop state of the flexible joint: four plant states, the order-5 EHGO, ``u``, ``z``.

    >>> import fl_design as fl
    >>> from fl_design.sim import ClosedLoop
    >>> from fl_design.sim._loop_jacobian import LoopLinearizer
    >>> loop = ClosedLoop(fl.plants.flexible_joint(), fl.presets.flexible_joint_design(), 4)
    >>> LoopLinearizer(loop).names
    ('q1', 'q1_dot', 'q2', 'q2_dot', 'xi_0', 'xi_1', 'xi_2', 'xi_3', 'xi_4', 'u', 'z')
    """

    def __init__(self, loop: ClosedLoop):
        self.loop = loop
        x, s = ca.SX.sym("x", loop.n), ca.SX.sym("s", loop.m)
        r, p = ca.SX.sym("r"), ca.SX.sym("p", loop.n_p)
        x_next, s_next = loop.sample(x, s, r, 0.0, 0.0, p)[:2]
        X, F = ca.vertcat(x, s), ca.vertcat(x_next, s_next)
        self.F = ca.Function("fl_lin_F", [X, r, p], [F, ca.jacobian(F, X)])
        Z = ca.vertcat(X, r, p)  # r and p ride along, so that fold() advances X alone
        self._advance = ca.Function("fl_lin_step", [Z], [ca.vertcat(F, r, p)])
        self._h = loop.plant.casadi().h
        self._folds: dict[int, ca.Function] = {}
        lay = loop.design.state_layout
        names = [str(sym) for sym in loop.plant.states]
        names += [f"xi_{i}" for i in range(lay["estimator"].stop)] + ["u", "z"]
        self.names = tuple(names)

    def _fold(self, n: int) -> ca.Function:
        if n not in self._folds:
            self._folds[n] = self._advance.fold(n)
        return self._folds[n]

    def start(self) -> np.ndarray:
        """The loop state at rest at the operating point (``u = u_eq``, ``z = 0``).

        Returns
        -------
        numpy.ndarray
            ``(n + m,)``: the plant's ``x_op``, the estimator at rest at its output, the
            controller's start input (``u_eq`` unless it sets one, clipped to its limits), 0.

        Examples
        --------
        The maglev rests at its 6 mm gap, the observer at that output, ``u`` at ``u_eq``:

        >>> import fl_design as fl
        >>> from fl_design.sim import ClosedLoop
        >>> from fl_design.sim._loop_jacobian import LoopLinearizer
        >>> loop = ClosedLoop(fl.plants.maglev(), fl.presets.maglev_design(), 4)
        >>> LoopLinearizer(loop).start().round(4).tolist()
        [0.006, 0.0, 0.8576, 0.006, 0.0, 0.0, 0.0, 9.4333, 0.0]
        """
        loop = self.loop
        y0 = float(self._h(loop.plant.x_op))
        ctrl = loop.design.controller
        u0 = loop.plant.u_eq if ctrl.u0 is None else ctrl.u0
        if ctrl.u_range is not None:
            u0 = float(np.clip(u0, *ctrl.u_range))
        return np.concatenate([loop.plant.x_op, loop.design.initial_state(y0=y0, u0=u0)])

    def _eval(self, X, r, p):
        F, J = (np.asarray(v, dtype=float) for v in self.F(X, r, p))
        return F.ravel() - X, J

    def _newton(self, X, r, p, iterations: int):
        """``(X, J, G, converged)`` after at most ``iterations`` damped Newton steps."""
        G, J = self._eval(X, r, p)
        for k in range(iterations + 1):
            if not np.all(np.isfinite(G)):
                return X, J, G, False
            if np.all(np.abs(G) <= fixed_point_tolerance(X, J)):
                return X, J, G, True
            if k == iterations:
                break
            step = np.linalg.lstsq(J - np.eye(X.size), -G, rcond=1e-12)[0]
            merit = _merit(G, X)
            for _ in range(LINE_SEARCH_HALVINGS + 1):
                Xn = X + step
                Gn, Jn = self._eval(Xn, r, p)
                if np.all(np.isfinite(Gn)) and _merit(Gn, Xn) < merit:
                    break
                step = step / 2
            else:
                return X, J, G, False  # no decrease along the Newton direction: stagnated
            X, G, J = Xn, Gn, Jn
        return X, J, G, False

    def _settle(self, r, p):
        """Simulate from the operating point at ``r``, Newton polishing after each chunk.

        Returns ``(last, samples, outcome)``: ``last = (X, J, G)`` after the last polish (None
        if the simulation diverged) and ``outcome`` one of ``"settled"``, ``"elsewhere"`` (a
        fixed point not holding ``r``), ``"diverged"``, ``"not settled"``.
        """
        z = np.concatenate([self.start(), [r], p])
        N = z.size - 1 - p.size
        fold = self._fold(SETTLE_CHUNK)  # one folded function, applied chunk after chunk
        done, check, last = 0, SETTLE_CHUNK, None
        while done < SETTLE_SAMPLES:
            z = np.asarray(fold(z), dtype=float).ravel()
            done += SETTLE_CHUNK
            X = z[:N]
            if not np.all(np.isfinite(X)) or np.max(np.abs(X)) > 1e150:
                return None, done, "diverged"
            if done < check:
                continue
            check *= 2  # polish after 1, 2, 4, ... chunks
            Xp, J, G, ok = self._newton(X.copy(), r, p, POLISH_ITERATIONS)
            last = (Xp, J, G)
            if ok and self._holds(Xp, r):
                return last, done, "settled"
            if ok and np.max(np.abs(X - Xp) / np.maximum(1.0, np.abs(Xp))) <= 1e-6:
                return last, done, "elsewhere"  # the run itself sits at a fixed point off r
        return last, done, "not settled"

    def _holds(self, X, r) -> bool:
        y = float(self._h(X[: self.loop.n]))
        return abs(y - r) <= math.sqrt(UNIT) * max(1.0, abs(r))

    def equilibrium(self, r: float, p: np.ndarray, *, start=None):
        """``(X, J, source, residual)``: the fixed point, its Jacobian and how it was found.

        Parameters
        ----------
        r : float
            Constant reference.
        p : numpy.ndarray
            Design parameter vector.
        start : array_like, optional
            Newton's first iterate (default :meth:`start`, rest at the operating point).

        Returns
        -------
        tuple
            ``X`` the loop state at the fixed point, ``J = dF/dX`` there, ``source`` as
            :attr:`SampledLinearization.equilibrium_source`, ``residual`` ``max |F(X) - X|``.

        Raises
        ------
        ComputationError
            Neither Newton nor a simulation from the operating point gave a fixed point
            holding the output at ``r``: names ``r``, the residuals and what to try.
        """
        p = np.asarray(p, dtype=float).ravel()
        X0 = self.start() if start is None else np.asarray(start, dtype=float).ravel().copy()
        X, J, G, ok = self._newton(X0, r, p, NEWTON_ITERATIONS)
        if ok and self._holds(X, r):
            return X, J, "newton", float(np.max(np.abs(G)))
        newton_res = float(np.max(np.abs(G))) if np.all(np.isfinite(G)) else math.inf
        last, samples, outcome = self._settle(r, p)
        if outcome == "settled":
            Xs, Js, Gs = last
            return Xs, Js, "simulation", float(np.max(np.abs(Gs)))
        what = {"diverged": "diverged", "not settled": "did not settle",
                "elsewhere": "settled"}[outcome]
        if last is not None:
            y = float(self._h(last[0][: self.loop.n]))
            what += (f" (at its end max|F(X) - X| = {float(np.max(np.abs(last[2]))):.3g}, "
                     f"output y = {y:.6g} for the reference {r:.6g}")
            what += (", a fixed point away from the reference: an input or estimate held at "
                     "its limit)" if outcome == "elsewhere" else ")")
        raise ComputationError(
            f"no closed-loop equilibrium found for r={r!r}: Newton's method from the operating "
            f"point stopped with max|F(X) - X| = {newton_res:.3g} (per-component tolerance "
            f"{TOL_ULPS:g} ulps of the state's scale), and a simulation from the operating "
            f"point {what} after {samples} samples ({samples * self.loop.T:.4g} s); the loop "
            "may not hold this reference (input saturation, a reference outside the region) "
            "or may oscillate around it: run fl.simulate at this reference to see what it "
            "does, or use a reference the plant can hold (default: the output at its "
            "operating point)")

    def __call__(self, r: float, p: np.ndarray, *, start=None) -> SampledLinearization:
        """The loop linearized at its equilibrium for reference ``r`` and parameters ``p``.

        Parameters
        ----------
        r : float
            Constant reference.
        p : numpy.ndarray
            Design parameter vector (:meth:`fl_design.Design.parameter_vector`).
        start : array_like, optional
            Newton's first iterate (default: rest at the operating point).

        Returns
        -------
        SampledLinearization
            Matrix, eigenvalues and spectral radius at the equilibrium, and how it was found.

        Examples
        --------
        >>> import fl_design as fl
        >>> from fl_design.sim import ClosedLoop
        >>> from fl_design.sim._loop_jacobian import LoopLinearizer
        >>> d = fl.presets.pendulum_design()
        >>> lin = LoopLinearizer(ClosedLoop(fl.plants.pendulum(), d, substeps=4))
        >>> round(float(lin(0.2, d.parameter_vector()).x_eq[0]), 12)
        0.2
        """
        X, M, source, residual = self.equilibrium(r, p, start=start)
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
            T=self.loop.T, equilibrium_source=source, residual=residual,
            tolerance=fixed_point_tolerance(X, M),
        )


def _merit(G: np.ndarray, X: np.ndarray) -> float:
    """Size of the residual relative to the state's scale (what the line search decreases)."""
    return float(np.linalg.norm(G / np.maximum(1.0, np.abs(X))))


__all__ = ["LoopLinearizer", "SampledLinearization", "fixed_point_tolerance"]
