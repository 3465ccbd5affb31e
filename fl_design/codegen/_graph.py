"""The step the C computes: ``Design.step`` with the controller's numbers as run-time parameters.

The estimator update is the design's own (:meth:`Estimator.symbolic_update`, its numbers
fixed), and the controller law is :meth:`DynamicController.symbolic_law` itself, called with
symbols in place of ``gamma``, the gains, ``k_I`` and the limits: the same law, not a second
copy, so that the C can read them from a parameter block at run time. Two additions a firmware
needs, both neutral at their defaults (the C then equals ``Design.step``):

- input limits ``u_min, u_max`` always exist (default: the design's, else ``-/+ U_OPEN``, a
  huge finite value that never clamps);
- the conditional-integration switch ``antiwindup`` of :class:`fl_design.DynamicController`
  (``z`` held while ``u`` sits on a limit and the integrator would push it further out) as a
  0/1 parameter, defaulting to the design's own setting (on, unless the design turned it off).

:func:`parameter_fields` names the block's fields in the order of the function's ``p`` input.

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen._graph import parameter_fields
>>> [f.name for f in parameter_fields(presets.paper_design())]  # doctest: +NORMALIZE_WHITESPACE
['gamma', 'k[0]', 'k[1]', 'ki', 'u_min', 'u_max', 'xhat_min[1]', 'xhat_max[1]', 'antiwindup']
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import casadi as ca
import numpy as np

from ..design import Design, DynamicController
from ..errors import ComputationError

#: the "no limit" value of an input limit the design does not have (finite: -ffast-math safe)
U_OPEN = 1e30


@dataclass(frozen=True)
class ParameterField:
    """One run-time parameter: its C member, default value and meaning.

    Parameters
    ----------
    name : str
        C member expression (``"gamma"``, ``"k[0]"``, ``"xhat_min[1]"``).
    value : float
        Default (the design's number).
    what : str
        Meaning, for the header's comment.

    Examples
    --------
    >>> from fl_design.codegen._graph import ParameterField
    >>> ParameterField("ki", 0.0, "integral gain").name
    'ki'
    """

    name: str
    value: float
    what: str


def parameter_fields(design: Design) -> tuple[ParameterField, ...]:
    """The parameter block of ``design``'s C step, in the order of the ``p`` input.

    Parameters
    ----------
    design : Design
        The design whose controller's numbers (``gamma``, gains, ``k_I``, limits, estimate
        clamps) are the fields and their defaults.

    Returns
    -------
    tuple of ParameterField

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._graph import parameter_fields
    >>> parameter_fields(presets.paper_design())[0].value
    0.0003
    """
    ctrl = design.controller
    out = [ParameterField("gamma", float(ctrl.gamma), "controller gain gamma (sign of b)")]
    out += [ParameterField(f"k[{i}]", float(k), f"gain k_{i + 1}")
            for i, k in enumerate(ctrl.gains)]
    out.append(ParameterField("ki", float(ctrl.ki), "integral gain k_I"))
    lo, hi = ctrl.u_range if ctrl.u_range is not None else (-U_OPEN, U_OPEN)
    out += [ParameterField("u_min", float(lo), "input limit, low"),
            ParameterField("u_max", float(hi), "input limit, high")]
    for i, lim in enumerate(ctrl.estimate_ranges):
        if lim is not None:
            out += [ParameterField(f"xhat_min[{i}]", float(lim[0]), f"clamp of xhat_{i + 1}, low"),
                    ParameterField(f"xhat_max[{i}]", float(lim[1]),
                                   f"clamp of xhat_{i + 1}, high")]
    out.append(ParameterField("antiwindup", float(ctrl.antiwindup),
                              "1: hold z while u is on a limit and z pushes it out; 0: off"))
    return tuple(out)


def parametric_core(design: Design, name: str = "fl_core") -> ca.Function:
    """``name(x, y, r, p) -> (x_next, u, xhat)``: the design's step with the parameter block ``p``.

    ``xhat`` are the clamped estimates ``[xhat_1 .. xhat_rho, sigmahat]`` of the sample (the
    telemetry frame's).

    Parameters
    ----------
    design : Design
        The design whose step is generated (e.g. its EHGO in the delta realization).
    name : str, optional
        Function name.

    Returns
    -------
    casadi.Function

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design import presets
    >>> from fl_design.codegen._graph import parametric_core, parameter_fields
    >>> d = presets.paper_design()
    >>> p = [f.value for f in parameter_fields(d)]
    >>> s = d.initial_state(y0=0.1)
    >>> a = parametric_core(d)(s, 0.12, 0.3, p)[1]
    >>> b = d.step(s, 0.12, 0.3)[1]
    >>> bool(abs(float(a) - float(b)) <= 1e-15 * abs(float(b)))
    True
    """
    fields = parameter_fields(design)
    est, ctrl, rho = design.estimator, design.controller, design.rho
    m = int(est.state_size)
    x, y, r = ca.SX.sym("x", m + 2), ca.SX.sym("y"), ca.SX.sym("r")
    p = ca.SX.sym("p", len(fields))
    sym = {f.name: p[i] for i, f in enumerate(fields)}
    ranges = [None if lim is None else (sym[f"xhat_min[{i}]"], sym[f"xhat_max[{i}]"])
              for i, lim in enumerate(ctrl.estimate_ranges)]
    shim = SimpleNamespace(rho=rho, gains=[sym[f"k[{i}]"] for i in range(rho)], ki=sym["ki"],
                           estimate_ranges=ranges, u_range=(sym["u_min"], sym["u_max"]),
                           antiwindup=sym["antiwindup"])
    xhat, xi_next, ready = est.symbolic_update(x[:m], y, ca.DM(est.parameter_vector()))
    u_prev, z_prev = x[m], x[m + 1]
    u, z, xhat_c = DynamicController.symbolic_law(shim, xhat, r, u_prev, z_prev, ready,
                                                  sym["gamma"], design.T)
    return ca.Function(name, [x, y, r, p], [ca.vertcat(xi_next, u, z), u, xhat_c],
                       ["x", "y", "r", "p"], ["x_next", "u", "xhat"])


def unsaturated_input(core: ca.Function) -> ca.Function:
    """``v(x, y, r, p)``: the input of ``core`` (:func:`parametric_core`) before its limits.

    The ``v`` of ``u = min(max(v, u_min), u_max)`` (through the least-squares estimator's hold
    select): the value whose finiteness the C's saturated branches test (:mod:`._finite`).

    Parameters
    ----------
    core : casadi.Function
        The parametric step.

    Returns
    -------
    casadi.Function

    Raises
    ------
    ComputationError
        ``u`` has no input limit (the parametric step always has one).

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._graph import parameter_fields, parametric_core, unsaturated_input
    >>> d = presets.paper_design()
    >>> p = [f.value for f in parameter_fields(d)]
    >>> s = d.initial_state(y0=0.0)
    >>> float(unsaturated_input(parametric_core(d))(s, 0.0, -1e4, p)) < -2.5  # beyond u_min
    True
    """
    args = [ca.SX.sym(n, core.size1_in(i)) for i, n in enumerate(core.name_in())]
    stack = [core(*args)[1]]
    while stack:
        e = stack.pop()
        if e.is_op(ca.OP_FMIN) and e.dep(0).is_op(ca.OP_FMAX):
            return ca.Function("v", args, [e.dep(0).dep(0)], core.name_in(), ["v"])
        if e.is_op(ca.OP_ADD) or e.is_op(ca.OP_IF_ELSE_ZERO):
            stack += [e.dep(i) for i in range(e.n_dep())]
    raise ComputationError(f"{core.name()}: u has no input limit min(max(v, lo), hi)")


def start_map(design: Design) -> tuple[np.ndarray, np.ndarray]:
    """``(c0, c1)``: the estimator's state at rest at a constant output ``y0`` is ``c0 + c1 y0``.

    The state is :meth:`Estimator.initial_state` (the steady state of the update for constant
    ``y = y0``: zero derivative estimates and ``sigmahat = 0``, the plant at rest); it is
    affine in ``y0`` for every estimator of the library, which is checked here at a third point.

    Parameters
    ----------
    design : Design
        The design whose step is generated.

    Returns
    -------
    tuple of numpy.ndarray

    Raises
    ------
    ComputationError
        The estimator's initial state is not affine in ``y0``.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._graph import start_map
    >>> c0, c1 = start_map(presets.paper_design())
    >>> c0.tolist(), c1.round(12).tolist()
    ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    """
    est = design.estimator
    state = lambda y0: np.asarray(est.initial_state(y0=y0), dtype=float).ravel()
    c0 = state(0.0)
    c1 = state(1.0) - c0
    probe = state(-2.5)
    if not np.allclose(probe, c0 - 2.5 * c1, rtol=1e-12, atol=1e-12 * (1 + np.abs(c1).max())):
        raise ComputationError(
            f"{type(est).__name__}.initial_state is not affine in y0; the C start "
            "(PREFIX_start) cannot be generated for it")
    return c0, c1


__all__ = ["U_OPEN", "ParameterField", "parameter_fields", "parametric_core", "start_map",
           "unsaturated_input"]
