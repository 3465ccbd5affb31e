"""The float step's observer without its level: the EHGO's delta update about the last sample.

Where the single-precision step loses its bits (measured per operation against double with
:func:`fl_design.codegen._float_check.emulate`, the flexible-joint preset, rho = 4): the
observer's first state ``xi_0`` sits at the output's level, so its rounding at every update
(half an ulp of the level: ``3e-8`` at 0.6 rad) is read back by the next innovation
``e_0 = xi_0 - y`` as measurement noise and reaches ``sigmahat`` amplified by ``~1 / eps^rho``.
That one rounding gave ``5.1e-4`` of ``max|u|`` on the preset's test vectors, every other
operation together ``1.7e-5``. The second loss, on a closed-loop record (``Scenario(0.05,
3.0)``, ``max|u| = 0.2``): the matrix ``G`` rounded entry by entry to float, ``8.9e-4``
there (the rounded entries no longer describe a chain of integrators, so a ramp in ``y``
leaves a bias in ``sigmahat``); the recursion below keeps the chain exact (one ``alpha``
everywhere), and its constants' rounding cost ``3e-8``.

:class:`LevelFreeEHGO` is the same observer (the same ``G``, ``D^-1``, parameter vector and
input-output map in real arithmetic) with its state about the last sample::

    xi = [s, xi_1 .. xi_rho, y_last],   s = xi_0 - y_last
    e_0 = s + (y_last - y),   g = G [e_0, xi_1 .. xi_rho]
    xhat = D^-1 [y + (e_0 + theta g_0), xi_i + theta g_i]
    xi+ = [e_0 + g_0, xi_i + g_i, y]

Every stored value is small (the innovation, the scaled derivatives) and ``y_last - y`` is a
difference of two nearby floats (exact when within a factor 2 of each other): no value the
observer reads back carries the level's rounding. The update ``g = G e`` is computed as its
recursion (:meth:`LevelFreeEHGO.recursion`, the Q31 step's: :mod:`._q31_realize`), fewer
operations than the matrix (the TRMS step 38 additions and products instead of 41, the
flexible joint 58 instead of 83). Measured (emulated float against ``Design.step`` in double):
the flexible joint's test vectors ``4.5e-4 -> 5.4e-6`` of ``max|u|``, its closed-loop
arithmetic ``2.4e-3 -> 8e-6``; the TRMS, maglev, pendulum, heater and rho = 3 chain lower too
(``tests/codegen/test_float_realization.py``). What stays in a closed-loop comparison with
``Design.step`` fed the recorded (double) measurements is the measurement's own rounding to
float (:func:`._float_check.float_error_budget`).

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen._float_realize import level_free
>>> d = level_free(presets.flexible_joint_design())
>>> type(d.estimator).__name__, d.state_size
('LevelFreeEHGO', 8)
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..design import EHGO, Design
from ..design._ehgo_discretization import _THETA
from ..design._estimator import as_casadi, check_length, rows


class LevelFreeEHGO(EHGO):
    """An EHGO's delta realization with the state about the last sample (module docstring).

    Its fields, ``G`` and parameter vector are the EHGO's own (build it with
    ``realization="delta"``); the state has one entry more (``y_last``), its first entry is
    ``xi_0 - y_last``. The observer's views (:meth:`continuous`, :meth:`filter`) are those of
    the plain EHGO.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen._float_realize import LevelFreeEHGO
    >>> obs = LevelFreeEHGO(2, 0.05, 1e-3, realization="delta")
    >>> obs.state_size, obs.initial_state(y0=0.5).tolist()
    (4, [0.0, 0.0, 0.0, 0.5])
    """

    @property
    def state_size(self) -> int:
        """``rho + 2``: ``[xi_0 - y_last, xi_1 .. xi_rho, y_last]``."""
        return self.rho + 2

    @property
    def flops_per_step(self) -> int:
        """The delta realization's count and two additions."""
        return self.plain().flops_per_step + 2

    def plain(self) -> EHGO:
        """The EHGO (delta realization) this one computes.

        Returns
        -------
        EHGO

        Examples
        --------
        >>> from fl_design.codegen._float_realize import LevelFreeEHGO
        >>> LevelFreeEHGO(1, 0.1, 1e-3, realization="delta").plain().state_size
        2
        """
        return EHGO(self.rho, self.eps, self.T, self.coeffs, self.method,
                    allow_unstable=self.allow_unstable, realization="delta")

    def continuous(self):
        """The plain observer's continuous model (:meth:`EHGO.continuous`)."""
        return self.plain().continuous()

    def filter(self, y_samples, *, xi0=None):
        """The plain observer's estimates (:meth:`EHGO.filter`; ``xi0`` in its coordinates)."""
        return self.plain().filter(y_samples, xi0=xi0)

    def initial_state(self, *, y0: float | None = None, estimate=None,
                      params=None) -> np.ndarray:
        """The plain EHGO's start (:meth:`EHGO.initial_state`) about ``y_last = y0``.

        Returns
        -------
        numpy.ndarray
            ``(rho + 2,)``: ``[xi_0 - y0, xi_1 .. xi_rho, y0]``.

        Examples
        --------
        >>> from fl_design.codegen._float_realize import LevelFreeEHGO
        >>> LevelFreeEHGO(1, 0.1, 1e-3, realization="delta").initial_state(y0=2.0).tolist()
        [0.0, 0.0, 2.0]
        """
        xi = self.plain().initial_state(y0=y0, estimate=estimate, params=params)
        last = float(xi[0]) if y0 is None and estimate is not None else (
            0.0 if y0 is None else float(y0))
        return np.concatenate([[xi[0] - last], xi[1:], [last]]) + 0.0  # no negative zeros

    def symbolic_update(self, xi, y, p):
        """``(xhat_ext, xi_next, 1)`` (module docstring); ``p`` as :meth:`EHGO.parameter_vector`.

        Examples
        --------
        >>> import casadi, numpy as np
        >>> from fl_design.codegen._float_realize import LevelFreeEHGO
        >>> obs = LevelFreeEHGO(1, 0.1, 1e-3, realization="delta")
        >>> xhat, _, _ = obs.symbolic_update(casadi.DM([0.0, 0.0, 1.0]), 1.0,
        ...                                  obs.parameter_vector())
        >>> np.asarray(xhat).ravel().tolist()
        [1.0, 0.0]
        """
        import casadi

        xi, y, p = as_casadi(xi), as_casadi(y), as_casadi(p)
        n = self.rho + 1
        check_length("xi", xi, n + 1)
        check_length("p", p, n * n + n)
        e0 = xi[0] + (xi[n] - y)  # the innovation: small values only
        e = [e0] + [xi[i] for i in range(1, n)]
        rec = self.recursion()
        if rec is None:  # the matrix form
            theta = _THETA[self.method]
            g = casadi.mtimes(rows(p, 0, n, n), casadi.vertcat(*e))
            g = [g[i] for i in range(n)]
            t = [e[i] + theta * g[i] if theta else e[i] for i in range(n)]
        else:
            t, g = _recursion_terms(e, *rec)
        t[0] = y + t[0]  # the level once, read only by the controller
        xhat = p[n * n:] * casadi.vertcat(*t)
        xi_next = casadi.vertcat(*[e[i] + g[i] for i in range(n)], y)
        return xhat, xi_next, type(xi)(1.0)

    def recursion(self):
        """``(alpha, beta, kappa, b, alpha c)`` of the delta update as a recursion, or None.

        ``g = G e`` solved as ``(I - beta F) g = alpha F e`` (``beta = theta alpha``, ``F``
        the companion matrix of ``c = alphas``; :mod:`fl_design.codegen._q31_realize`):
        the chain of integrators (``alpha t_(i+1)``, one ``alpha`` everywhere) is exact
        whatever the constants' rounding, which only perturbs the gains (``alpha c_i``,
        ``b_i``, ``kappa`` multiply the innovation ``t_0``). None for the ZOH method or when
        the recursion does not reproduce ``G`` (:func:`._q31_realize._delta_recursion`).

        Returns
        -------
        tuple or None

        Examples
        --------
        >>> from fl_design.codegen._float_realize import LevelFreeEHGO
        >>> LevelFreeEHGO(1, 0.1, 1e-3, realization="delta").recursion()[:2]
        (0.01, 0.005)
        """
        from ._q31_realize import _delta_recursion

        rec = _delta_recursion(SimpleNamespace(estimator=self.plain()))  # reads the estimator
        if rec is None:
            return None
        alpha, beta, kappa, _, b, _ = rec
        return alpha, beta, kappa, tuple(b), tuple(alpha * c for c in self.alphas)


def _recursion_terms(e, alpha, beta, kappa, b, ac):
    """``(t, g)``: ``t = e + theta g`` and ``g = G e`` by the recursion (``t_0`` the
    innovation's, ``t_i`` read as the estimates); ``e`` CasADi scalars (SX or DM)."""
    n = len(e)
    a = [None] * n
    a[n - 1] = e[n - 1]
    for i in range(n - 2, -1, -1):
        a[i] = e[i] + beta * a[i + 1] if beta else e[i]
    t = [kappa * a[0]]
    t += [a[i] + b[i] * t[0] if b[i] else a[i] for i in range(1, n)]
    g = [alpha * t[i + 1] - ac[i] * t[0] for i in range(n - 1)]
    g.append(-ac[n - 1] * t[0])
    return t, g


def design_states(design: Design, states) -> np.ndarray:
    """Design states of ``design``'s step in the coordinates of the EHGO it computes.

    A :class:`LevelFreeEHGO`'s ``[s, xi_1 .. xi_rho, y_last, u, z]`` become ``[s + y_last,
    xi_1 .. xi_rho, u, z]`` (the user's design's state: the delta and direct realizations
    share it); any other design's states are returned as they are.

    Parameters
    ----------
    design : Design
        The generated design (:func:`~fl_design.codegen.step_design`).
    states : array_like
        ``(N, design.state_size)`` states.

    Returns
    -------
    numpy.ndarray

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design import presets
    >>> from fl_design.codegen._float_realize import design_states, level_free
    >>> d = level_free(presets.paper_design())
    >>> design_states(d, d.initial_state(y0=0.3, u0=1.0)[None, :]).tolist()
    [[0.3, 0.0, 0.0, 1.0, 0.0]]
    """
    states = np.asarray(states, dtype=float)
    if not isinstance(design.estimator, LevelFreeEHGO):
        return states
    n = design.rho + 1
    out = np.delete(states, n, axis=1)
    out[:, 0] = states[:, 0] + states[:, n]
    return out


def level_free(design: Design) -> Design:
    """``design`` with its EHGO as a :class:`LevelFreeEHGO` (other estimators: as it is).

    Parameters
    ----------
    design : Design
        The user's design or its delta form.

    Returns
    -------
    Design

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._float_realize import level_free
    >>> level_free(presets.paper_design()).estimator.state_size
    4
    """
    est = design.estimator
    if not isinstance(est, EHGO) or isinstance(est, LevelFreeEHGO):
        return design
    obs = LevelFreeEHGO(est.rho, est.eps, est.T, est.coeffs, est.method,
                        allow_unstable=est.allow_unstable, realization="delta")
    return Design(estimator=obs, controller=design.controller)


__all__ = ["LevelFreeEHGO", "design_states", "level_free"]
