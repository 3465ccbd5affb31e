"""A Design joins an estimator and the dynamic controller into the one loop-step function.

The step follows the normative sampled loop (estimator output, clamp, integrator, ``v``,
saturated dynamic law, estimator update) and is built once as a CasADi SX graph. Simulation,
sweeps and C generation call :attr:`Design.step` / :attr:`Design.parametric_step`; they never
re-implement the loop.

Examples
--------
>>> import fl_design as fl
>>> design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.05, T=1e-3),
...                    controller=fl.DynamicController((2, 4), 3e-4))
>>> design.step.name(), design.step.name_in(), design.step.name_out()
('fl_step', ['state', 'y', 'r'], ['state_next', 'u'])
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .. import _validate as v
from ..errors import DesignMismatchError, DimensionError, ParameterError
from ._controller import DynamicController
from ._estimator import Estimator
from ._layout import Layout


@dataclass(frozen=True)
class OpenLoopRun:
    """The loop step run over logged measurements (see :meth:`Design.run`).

    Parameters
    ----------
    u : numpy.ndarray
        ``(N,)`` inputs ``u_k`` the design computed.
    xhat : numpy.ndarray
        ``(N, rho + 1)`` estimates ``[xhat_1 .. xhat_rho, sigmahat]`` after clamping.
    state : numpy.ndarray
        ``(N + 1, state_size)`` design states, ``state[0]`` the initial one.

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.05, T=1e-3),
    ...               controller=fl.DynamicController((2, 4), 3e-4))
    >>> sorted(d.run([0.0, 0.1], 0.0).to_dict())
    ['state', 'u', 'xhat']
    """

    u: np.ndarray
    xhat: np.ndarray
    state: np.ndarray

    def to_dict(self) -> dict[str, list]:
        """Plain lists, ready for JSON.

        Examples
        --------
        >>> import numpy as np
        >>> OpenLoopRun(np.zeros(1), np.zeros((1, 3)), np.zeros((2, 5))).to_dict()["u"]
        [0.0]
        """
        return {"u": self.u.tolist(), "xhat": self.xhat.tolist(), "state": self.state.tolist()}


@dataclass(frozen=True)
class Design:
    """Estimator + dynamic controller: the sampled loop step as one CasADi function.

    State layout (a flat vector, see :attr:`state_layout`)::

        [ estimator state (estimator.state_size) ...,  u,  z ]

    ``u`` is the last (saturated) input ``u_(k-1)``, starting at ``controller.u0``; ``z`` is
    the integrator state, starting at 0.

    Parameters
    ----------
    estimator : EHGO or LeastSquaresEstimator
        An :class:`~fl_design.design.Estimator` (the declared interface).
    controller : DynamicController
        The dynamic controller; its ``rho`` must equal the estimator's.

    Attributes
    ----------
    parametric_step : casadi.Function
        ``fl_step_p(state, y, r, p) -> (state_next, u, xhat)`` with
        ``p = parameter_vector()`` (estimator parameters, then ``gamma``) and ``xhat`` the
        ``rho + 1`` estimates after clamping.
    step : casadi.Function
        ``fl_step(state, y, r) -> (state_next, u)``: ``parametric_step`` with ``p`` replaced by
        the design's own numbers (same symbolic graph).

    Raises
    ------
    DesignMismatchError
        The estimator and the controller serve different relative degrees.
    ParameterError
        ``estimator`` is not an :class:`~fl_design.design.Estimator`, or ``controller`` is not a
        :class:`DynamicController`.

    Examples
    --------
    The paper's Twin Rotor design:

    >>> import fl_design as fl
    >>> obs = fl.EHGO(rho=2, eps=0.05, T=1e-3, coeffs=(6, 11, 6))
    >>> ctrl = fl.DynamicController((2, 4), 3e-4, ki=1e-3, estimate_limits=(None, 0.05))
    >>> design = fl.Design(estimator=obs, controller=ctrl)
    >>> design.state_size, design.state_layout["u"]
    (5, slice(3, 4, None))
    >>> state_next, u = design.step(design.initial_state(), 0.0, 0.3)
    >>> float(u) > 0.0  # below the reference: the input rises
    True
    """

    estimator: Estimator
    controller: DynamicController

    def __post_init__(self) -> None:
        if not isinstance(self.estimator, Estimator):
            raise ParameterError(
                f"estimator must be an fl_design estimator (fl.EHGO or "
                f"fl.LeastSquaresEstimator, subclasses of fl.design.Estimator), got "
                f"{type(self.estimator).__name__}"
            )
        if not isinstance(self.controller, DynamicController):
            raise ParameterError(
                f"controller must be a fl.DynamicController, got {type(self.controller).__name__}"
            )
        if self.estimator.rho != self.controller.rho:
            raise DesignMismatchError(
                f"estimator rho={self.estimator.rho} ({type(self.estimator).__name__}) differs "
                f"from controller rho={self.controller.rho} (gains={self.controller.gains}); "
                "both must serve the same relative degree"
            )

    # --- sizes and numbers --------------------------------------------------------------
    @property
    def rho(self) -> int:
        """Relative degree served."""
        return self.controller.rho

    @property
    def T(self) -> float:
        """Sampling time (the estimator's)."""
        return float(self.estimator.T)

    @property
    def state_size(self) -> int:
        """Length of the design state: estimator state + ``u`` + ``z``."""
        return int(self.estimator.state_size) + 2

    @property
    def state_layout(self) -> Layout:
        """Where each part sits in the state vector: ``estimator``, ``u``, ``z``."""
        return Layout((("estimator", int(self.estimator.state_size)), ("u", 1), ("z", 1)))

    @property
    def parameter_layout(self) -> Layout:
        """Where each part sits in :meth:`parameter_vector`: ``estimator``, ``gamma``."""
        n = int(np.asarray(self.estimator.parameter_vector()).size)
        return Layout((("estimator", n), ("gamma", 1)))

    def initial_state(self, *, y0: float | None = None, estimate=None, u0: float | None = None,
                      params=None) -> np.ndarray:
        """Initial design state ``[estimator state, u0, 0]``: a bumpless start.

        Parameters
        ----------
        y0 : float, optional
            First measurement: the estimator starts at rest there (default 0).
        estimate : array_like, optional
            ``(rho + 1,)`` first estimates ``(y, y', ..., sigma)`` instead.
        u0 : float, optional
            Initial input ``u(-1)`` (default :attr:`DynamicController.u_start`; a run resolves
            ``u0=None`` to the plant's ``u_eq``).
        params : array_like, optional
            A :meth:`parameter_vector` (another ``eps``) the estimator's state is solved for.

        Returns
        -------
        numpy.ndarray
            ``(m,)`` in the order of :attr:`state_layout`: the estimator's state, ``u0``,
            the integrator's 0.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.05, T=1e-3),
        ...               controller=fl.DynamicController((2, 4), 3e-4, u0=0.5))
        >>> d.initial_state()[d.state_layout["u"]], d.initial_state(y0=0.1)[:3]
        (array([0.5]), array([0.1, 0. , 0. ]))
        """
        if params is not None:
            params = np.asarray(params, dtype=float).ravel()[: self.parameter_layout.size - 1]
        xi0 = np.asarray(self.estimator.initial_state(y0=y0, estimate=estimate, params=params),
                         dtype=float).ravel()
        u0 = self.controller.u_start if u0 is None else float(u0)
        return np.concatenate([xi0, [u0, 0.0]])

    def parameter_vector(self) -> np.ndarray:
        """Numbers a sweep may change: ``estimator.parameter_vector()`` then ``gamma``.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.05, T=1e-3),
        ...               controller=fl.DynamicController((2, 4), 3e-4))
        >>> float(d.parameter_vector()[-1])
        0.0003
        """
        p_obs = np.asarray(self.estimator.parameter_vector(), dtype=float).ravel()
        return np.concatenate([p_obs, [self.controller.gamma]])

    # --- the one symbolic graph ------------------------------------------------------------
    @functools.cached_property
    def _functions(self):
        import casadi as ca

        m = int(self.estimator.state_size)
        n_p = self.parameter_vector().size
        state = ca.SX.sym("state", m + 2)
        y, r = ca.SX.sym("y"), ca.SX.sym("r")
        p = ca.SX.sym("p", n_p)
        xhat_ext, xi_next, ready = self.estimator.symbolic_update(state[:m], y, p[: n_p - 1])
        u, z, xhat = self.controller.symbolic_law(
            xhat_ext, r, state[m], state[m + 1], ready, p[n_p - 1], self.T
        )
        state_next = ca.vertcat(xi_next, u, z)
        parametric = ca.Function(
            "fl_step_p", [state, y, r, p], [state_next, u, xhat],
            ["state", "y", "r", "p"], ["state_next", "u", "xhat"],
        )
        p0 = ca.DM(self.parameter_vector())
        fixed = ca.substitute([state_next, u], [p], [p0])
        step = ca.Function("fl_step", [state, y, r], fixed, ["state", "y", "r"],
                           ["state_next", "u"])
        return parametric, step

    @property
    def parametric_step(self):
        """``fl_step_p(state, y, r, p) -> (state_next, u, xhat)`` (casadi.Function)."""
        return self._functions[0]

    @property
    def step(self):
        """``fl_step(state, y, r) -> (state_next, u)`` with ``p = parameter_vector()``."""
        return self._functions[1]

    def __getstate__(self):  # the CasADi graph is rebuilt on demand after unpickling
        return {k: val for k, val in self.__dict__.items() if k != "_functions"}

    # --- derived designs and runs ----------------------------------------------------------
    def replace(self, *, eps: float | None = None, gamma: float | None = None,
                **unknown) -> Design:
        """A new design with the estimator's ``eps`` and/or the controller's ``gamma`` changed.

        Parameters
        ----------
        eps : float, optional
            New estimator time constant (only for estimators that have one, e.g. the EHGO).
        gamma : float, optional
            New controller gain.
        **unknown
            Refused: any other name raises ParameterError (change the estimator or the
            controller with their own ``replace`` and build a new Design).

        Raises
        ------
        ParameterError
            ``eps`` is given but the estimator has no ``eps`` (least-squares baseline), or an
            unknown keyword.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.05, T=1e-3),
        ...               controller=fl.DynamicController((2, 4), 3e-4))
        >>> d2 = d.replace(eps=0.01, gamma=1e-3)
        >>> d2.estimator.eps, d2.controller.gamma
        (0.01, 0.001)
        """
        if unknown:
            raise ParameterError(
                f"Design.replace takes eps and gamma only, got {sorted(unknown)}; change other "
                "numbers with design.estimator.replace(...) / design.controller.replace(...) "
                "and build a new fl.Design")
        estimator, controller = self.estimator, self.controller
        if eps is not None:
            if not estimator.has_time_constant:
                raise ParameterError(
                    f"eps={eps!r} cannot be set: {type(estimator).__name__} has no eps "
                    "(only the EHGO has an observer time constant); leave eps=None"
                )
            estimator = estimator.replace(eps=eps)
        if gamma is not None:
            controller = controller.replace(gamma=gamma)
        return Design(estimator=estimator, controller=controller)

    def run(self, y_sequence, r_sequence=0.0, *, state0=None) -> OpenLoopRun:
        """Run the loop step over given measurements (open loop: ``u`` is not fed back).

        Useful to check a logged experiment or to test the step. Evaluates
        :attr:`parametric_step` with CasADi's ``mapaccum``; nothing is re-implemented.

        Parameters
        ----------
        y_sequence : array_like
            ``(N,)`` measurements ``y_0 .. y_(N-1)``.
        r_sequence : array_like or float, optional
            ``(N,)`` references, or one value for all samples (default 0).
        state0 : array_like, optional
            Initial design state (default :meth:`initial_state`).

        Returns
        -------
        OpenLoopRun
            ``u`` (N,), ``xhat`` (N, rho + 1), ``state`` (N + 1, state_size).

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.05, T=1e-3),
        ...               controller=fl.DynamicController((2, 4), 3e-4, u_limits=(-1, 1)))
        >>> out = d.run([0.0, 0.5, 1.0], r_sequence=0.0)
        >>> out.u.shape, out.xhat.shape, out.state.shape
        ((3,), (3, 3), (4, 5))
        """
        y = v.real_vector("y_sequence", y_sequence)
        if y.size == 0:
            raise DimensionError("y_sequence must have at least one sample, got none")
        if np.ndim(r_sequence) == 0:
            r = np.full(y.size, v.real_scalar("r_sequence", r_sequence))
        else:
            r = v.real_vector("r_sequence", r_sequence, length=y.size)
        if state0 is None:
            x0 = self.initial_state()
        else:
            x0 = v.real_vector("state0", state0, length=self.state_size)
        p = np.tile(self.parameter_vector()[:, None], (1, y.size))
        states, u, xhat = self.parametric_step.mapaccum("fl_run", y.size)(x0, y[None, :],
                                                                        r[None, :], p)
        states = np.asarray(states, dtype=float).T
        return OpenLoopRun(
            u=np.asarray(u, dtype=float).ravel(),
            xhat=np.asarray(xhat, dtype=float).T,
            state=np.vstack([x0[None, :], states]),
        )

    # --- presentation ----------------------------------------------------------------------
    def describe(self) -> str:
        """A short multi-line summary of the design.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.05, T=1e-3),
        ...               controller=fl.DynamicController((2, 4), 3e-4))
        >>> print(d.describe())  # doctest: +ELLIPSIS
        Design (rho = 2, T = 0.001 s)
          estimator:  EHGO(...)
          controller: DynamicController(gains=(2, 4), gamma=0.0003)
          state:      [estimator 0:3, u 3, z 4]
        """
        lay = self.state_layout
        m = lay["u"].start
        return "\n".join([
            f"Design (rho = {self.rho}, T = {self.T:g} s)",
            f"  estimator:  {self.estimator!r}",
            f"  controller: {self.controller!r}",
            f"  state:      [estimator 0:{m}, u {m}, z {m + 1}]",
        ])

    def __repr__(self) -> str:
        return f"Design(estimator={self.estimator!r}, controller={self.controller!r})"


__all__ = ["Design", "OpenLoopRun"]
