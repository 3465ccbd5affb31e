"""Fewer products for the Q31 step: the EHGO's delta update as its recursion.

The delta realization ``xi' = xi + G e`` (``e = xi - e_1 y``) of an ``n``-state EHGO costs
``n^2`` products per step as a matrix, and the controller ``n`` more (``K xhat``, ``xhat =
D^-1 (xi + theta G e)``). ``G = (I - theta alpha F)^-1 alpha F`` (``F`` the companion matrix
of the observer's coefficients ``c``, ``alpha = T / eps``, ``theta`` the method's weight) is a
recursion (:func:`_delta_recursion`): with ``beta = theta alpha``,

    a_(n-1) = e_(n-1),  a_i = e_i + beta a_(i+1),  t_0 = kappa a_0,  t_i = a_i + b_i t_0,
    g_i = alpha t_(i+1) - alpha c_i t_0,   xhat_0 = d_0 (t_0 + y),  xhat_i = d_i t_i

(``t_n = 0``, ``b_n = 0``, ``b_i = beta b_(i+1) - beta c_i``, ``kappa = 1 / (1 - b_0)``; ``t_i
= e_i + theta g_i``, so ``xhat = D^-1 (xi + theta g)``): ``4 n - 2`` products, fewer where
``alpha``, ``beta`` or a coefficient is a power of two (a shift) or two products repeat. The
estimates are read from ``t_i``, their own (small) values: a sum ``a_i + b_i t_0`` of large
terms that cancel, read by the controller's large gains, would lose the bits the terms
carry. The controller reads the estimates only through a few linear functionals (the error
``xhat_1 - r``, the law ``sum k_i xhat_i + sigmahat``, a clamped estimate):
:func:`collapse_affine` prints each once as a sum over ``t, y, r, u, z``. The observer keeps
its coordinates: its state, start and boxes are the delta realization's own.

The rewritten step is used only when it agrees with the observer's own in double precision
on a random record within the range (``1e-9`` of each state entry's peak) and has fewer
products; otherwise (another estimator, the ZOH method, a mismatch) the step keeps the
matrix form, with the reason.

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen import step_design
>>> from fl_design.codegen._q31_realize import delta_realization
>>> real = delta_realization(step_design(presets.flexible_joint_design(), "q31"), (-3, 3))
>>> real.name, real.why
('recursion', '')
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ._q31_factor import factor_constants

#: the realization's step against the observer's own, relative to the values' scale
_AGREE = 1e-9
_AFFINE = (ca.OP_ADD, ca.OP_SUB, ca.OP_NEG, ca.OP_TWICE, ca.OP_ASSIGN, ca.OP_MUL)


def linear_maps(design):
    """``(A, B)``: the estimator's update linearized at zero (``xi_next = A xi + B y``)."""
    est = design.estimator
    m = int(est.state_size)
    xi, y = ca.SX.sym("xi", m), ca.SX.sym("y")
    _, xi_next, _ = est.symbolic_update(xi, y, ca.DM(est.parameter_vector()))
    f = ca.Function("lin", [xi, y], [ca.jacobian(xi_next, xi), ca.jacobian(xi_next, y)])
    A, B = (np.asarray(v, dtype=float) for v in f(np.zeros(m), 0.0))
    return A, B.ravel()


def fixed_core(design):
    """The step's core ``(x, y, r) -> (x_next, u)`` with the design's numbers, products by
    constants equal up to a power of two shared (:func:`._q31_factor.factor_constants`)."""
    from ._graph import parameter_fields, parametric_core

    f = parametric_core(design)
    n = design.state_size
    x, y, r = ca.SX.sym("x", n), ca.SX.sym("y"), ca.SX.sym("r")
    x_next, u, _ = f(x, y, r, [fl.value for fl in parameter_fields(design)])
    return factor_constants(ca.Function("q31_core", [x, y, r], [x_next, u]))


@dataclass(frozen=True)
class Realization:
    """The core the Q31 program is built from and its observer's linear update.

    Parameters
    ----------
    name : str
        ``"recursion"`` (:func:`delta_realization`) or ``"direct"`` (the matrix form).
    core : casadi.Function
        ``(x, y, r) -> (x_next, u)`` with the design's numbers fixed.
    A, B : numpy.ndarray
        The observer's update ``xi' = A xi + B y`` (its peak-gain boxes).
    why : str
        Why the recursion was not used (empty when it was).
    """

    name: str
    core: ca.Function
    A: np.ndarray
    B: np.ndarray
    why: str = ""


def collapse_affine(g: ca.Function) -> ca.Function:
    """``g`` with each value that a non-affine operation reads (or an output) computed as
    one sum over the inputs and the non-affine results it depends on.

    Every value of ``g`` is an affine form in its *leaves* (the inputs and the results of
    operations other than ``+``, ``-``, negation, doubling and a product by a constant). A
    form that a non-affine operation (a comparison, ``min``, ``max``, a product of two
    values...) or an output reads is printed once, ``c_0 + sum_j c_j leaf_j``, and becomes a
    leaf itself; the sums between are never formed. The same values in real arithmetic.

    Parameters
    ----------
    g : casadi.Function
        An SX function of one vector input.

    Returns
    -------
    casadi.Function

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.codegen._q31_realize import collapse_affine
    >>> s = ca.SX.sym("s", 3)
    >>> xhat = [s[0] + 2 * s[1], 3 * s[1] - s[2]]
    >>> g = collapse_affine(ca.Function("g", [s], [ca.fmax(4 * xhat[0] + xhat[1], 0)]))
    >>> float(g([1.0, 1.0, 1.0]))
    14.0
    """
    n = g.n_instructions()
    cur, need = {}, set()
    for k in range(n):  # which values a non-affine operation or an output reads
        op, ins, out = g.instruction_id(k), g.instruction_input(k), g.instruction_output(k)
        if op == ca.OP_OUTPUT:
            need.add(cur[ins[0]])
            continue
        if op not in (ca.OP_INPUT, ca.OP_CONST):
            a = [cur[i] for i in ins if i >= 0]
            if op not in _AFFINE:
                need.update(a)
        cur[out[0]] = k
    s = ca.SX.sym(g.name_in(0), g.sparsity_in(0))
    leaves, forms, cur = [], {}, {}
    outs = [None] * g.nnz_out(0)

    def leaf(e):
        leaves.append(e)
        return {len(leaves) - 1: 1.0}, 0.0

    def scale(f, c):
        return {j: v * c for j, v in f[0].items() if v * c != 0.0}, f[1] * c

    def add(f1, f2, sign):
        d = dict(f1[0])
        for j, v in f2[0].items():
            d[j] = d.get(j, 0.0) + sign * v
        return {j: v for j, v in d.items() if v != 0.0}, f1[1] + sign * f2[1]

    for k in range(n):
        op, ins, out = g.instruction_id(k), g.instruction_input(k), g.instruction_output(k)
        if op == ca.OP_OUTPUT:
            outs[out[1]] = _sx(forms[cur[ins[0]]], leaves)
            continue
        a = [cur[i] for i in ins if i >= 0] if op not in (ca.OP_INPUT, ca.OP_CONST) else []
        fa = [forms[j] for j in a]
        if op == ca.OP_INPUT:
            f = leaf(s.nz[ins[1]])
        elif op == ca.OP_CONST:
            f = ({}, g.instruction_constant(k))
        elif op in (ca.OP_ADD, ca.OP_SUB):
            f = add(fa[0], fa[1], 1.0 if op == ca.OP_ADD else -1.0)
        elif op == ca.OP_NEG:
            f = scale(fa[0], -1.0)
        elif op == ca.OP_TWICE:
            f = scale(fa[0], 2.0)
        elif op == ca.OP_ASSIGN:
            f = fa[0]
        elif op == ca.OP_MUL and (not fa[0][0] or not fa[1][0]):
            c, other = (fa[0], fa[1]) if not fa[0][0] else (fa[1], fa[0])
            f = scale(other, c[1])
        else:
            args = [_sx(v, leaves) for v in fa]
            e = ca.SX.binary(op, *args) if len(args) == 2 else ca.SX.unary(op, args[0])
            f = leaf(e)
        if k in need and len(f[0]) + (f[1] != 0.0) > 1:
            f = leaf(_sx(f, leaves))  # read by a non-affine operation: printed once
        forms[k] = f
        cur[out[0]] = k
    return ca.Function(g.name(), [s], [ca.vertcat(*outs)], g.name_in(), g.name_out())


def _sx(f, leaves) -> ca.SX:
    terms, const = f
    total = None
    for j in sorted(terms):
        c = terms[j]
        t = leaves[j] if c == 1.0 else -leaves[j] if c == -1.0 else ca.SX(c) * leaves[j]
        if total is None:
            total = t
        elif c == -1.0:
            total = total - leaves[j]
        else:
            total = total + t
    if total is None:
        return ca.SX(const)
    return total if const == 0.0 else total + const


def _controller_of(design, lin_xhat, leaves_n):
    """``g(s) -> (u, z)`` with ``s = [leaves..., y, r, u_prev, z_prev]``: the design's law fed
    ``xhat = lin_xhat(s)`` (affine), collapsed (:func:`collapse_affine`)."""
    s = ca.SX.sym("s", leaves_n + 4)
    r, u_prev, z_prev = (s[leaves_n + i] for i in range(1, 4))
    ctrl = design.controller
    u, z, _ = ctrl.symbolic_law(lin_xhat(s), r, u_prev, z_prev, 1, ctrl.gamma, design.T)
    return collapse_affine(ca.Function("g", [s], [ca.vertcat(u, z)]))


def _delta_recursion(design):
    """The EHGO's delta update ``g = G e`` as its recursion (module docstring), or None.

    Returns ``(alpha, beta, kappa, gamma, b, d)`` (``gamma_i = alpha (b_(i+1) - c_i)``: ``g_i
    = alpha a_(i+1) + gamma_i t_0``, how the check below applies it) when ``G`` (as the
    estimator computes it) is this recursion within ``1e-12`` of its largest entry; None for
    another estimator, the ZOH method or a mismatch."""
    from ..design import EHGO
    from ..design._ehgo_discretization import _THETA

    est = design.estimator
    if not isinstance(est, EHGO) or est.realization != "delta" or est.method == "zoh":
        return None
    theta = 1.0 if est.method == "backward_euler" else _THETA[est.method]
    n, alpha, c = int(est.state_size), float(est.alpha), [float(v) for v in est.alphas]
    beta = theta * alpha
    b = [0.0] * (n + 1)
    for i in range(n - 1, -1, -1):
        b[i] = beta * b[i + 1] - beta * c[i]
    if b[0] == 1.0:
        return None
    kappa = 1.0 / (1.0 - b[0])
    gam = [alpha * (b[i + 1] - c[i]) for i in range(n)]
    G = np.asarray(est.delta_matrix, dtype=float)
    Gs = np.zeros((n, n))
    for j in range(n):  # G_s e_j
        e = np.zeros(n)
        e[j] = 1.0
        a = np.zeros(n + 1)
        for i in range(n - 1, -1, -1):
            a[i] = e[i] + beta * a[i + 1]
        t0 = kappa * a[0]
        Gs[:, j] = [alpha * a[i + 1] + gam[i] * t0 for i in range(n)]
    if not np.max(np.abs(Gs - G)) <= 1e-12 * max(1.0, float(np.max(np.abs(G)))):
        return None
    return alpha, beta, kappa, gam, b, [float(v) for v in est.unscaling]


def delta_realization(design, y_range, core=None) -> Realization:
    """The step of ``design`` with its EHGO's delta update as a recursion (same coordinates).

    See the module docstring; the controller reads the estimates through the sums
    :func:`collapse_affine` prints. The observer keeps its coordinates (its state, start and
    boxes are the delta realization's own); only the order of the operations changes.

    Parameters
    ----------
    design : Design
        The generated design (after :func:`~fl_design.codegen.step_design`).
    y_range : (float, float)
        The range of ``y`` and ``r`` (the agreement check runs within it).
    core : casadi.Function, optional
        ``(x, y, r) -> (x_next, u)`` as the estimator computes it (default: built here).

    Returns
    -------
    Realization
        ``name == "direct"`` (with ``why``) when the recursion does not apply.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import step_design
    >>> from fl_design.codegen._q31_realize import delta_realization
    >>> delta_realization(step_design(presets.maglev_design(), "q31"), (0.0, 0.02)).name
    'recursion'
    """
    f0 = fixed_core(design) if core is None else core
    m = int(design.estimator.state_size)
    A, B = linear_maps(design)
    rec = _delta_recursion(design)
    if rec is None:
        return Realization("direct", f0, A, B, "not an EHGO delta update of the bilinear or "
                           "Euler methods")
    alpha, beta, kappa, _, b, dinv = rec
    c = [float(v) for v in design.estimator.alphas]

    def lin_xhat(s):  # s = [t_1 .. t_(m-1), t_0, y, ...]
        t0, y = s[m - 1], s[m]
        return ca.vertcat(dinv[0] * (t0 + y), *[dinv[i] * s[i - 1] for i in range(1, m)])

    g = _controller_of(design, lin_xhat, m)
    x, y, r = ca.SX.sym("x", m + 2), ca.SX.sym("y"), ca.SX.sym("r")
    e = [x[0] - y] + [x[i] for i in range(1, m)]
    a = [None] * (m + 1)
    a[m - 1] = e[m - 1]
    for i in range(m - 2, -1, -1):
        a[i] = e[i] + ca.SX(beta) * a[i + 1] if beta else e[i]
    t = [ca.SX(kappa) * a[0]]
    t += [a[i] + ca.SX(b[i]) * t[0] if b[i] else a[i] for i in range(1, m)] + [ca.SX(0)]
    xi_next = [x[i] + ca.SX(alpha) * t[i + 1] - ca.SX(alpha * c[i]) * t[0] if i + 1 < m
               else x[i] - ca.SX(alpha * c[i]) * t[0] for i in range(m)]
    uz = g(ca.vertcat(*t[1:m], t[0], y, r, x[m], x[m + 1]))
    shared = factor_constants(ca.Function("q31_core", [x, y, r],
                                          [ca.vertcat(*xi_next, uz[0], uz[1]), uz[0]]))
    x_next, u = shared(x, y, r)  # one product per constant and operand (the factoring and
    outs = ca.cse(ca.vertcat(x_next, u))  # the collapse repeat some)
    core = ca.Function("q31_core", [x, y, r], [outs[:m + 2], outs[m + 2]])
    why = _disagreement(design, f0, core, y_range)
    if why:
        return Realization("direct", f0, A, B, why)
    return Realization("recursion", core, A, B, "")


def _disagreement(design, f0, f1, y_range, n: int = 400, seed: int = 0) -> str:
    """Empty when the two cores give the same state (within ``_AGREE`` of each entry's peak)
    on a random record within ``y_range`` from the rest state at its middle; else the
    reason."""
    lo, hi = (float(v) for v in y_range)
    rng = np.random.default_rng(seed)
    y0 = 0.5 * (lo + hi)
    xi = np.asarray(design.estimator.initial_state(y0=y0), dtype=float).ravel()
    x0 = np.concatenate([xi, [float(np.clip(0.0, *design.controller.u_range)), 0.0]])
    ys = np.clip(y0 + np.cumsum(rng.normal(0.0, 0.02 * (hi - lo), n)), lo, hi)
    rs = np.where(np.arange(n) < n // 2, y0, lo + 0.7 * (hi - lo))
    a, b, diff, peak = x0, x0, [], []
    for yk, rk in zip(ys, rs):
        a = np.asarray(f0(a, yk, rk)[0], dtype=float).ravel()
        b = np.asarray(f1(b, yk, rk)[0], dtype=float).ravel()
        diff.append(np.abs(a - b))
        peak.append(np.abs(a))
    worst = float(np.max(np.max(diff, axis=0) / np.maximum(np.max(peak, axis=0), 1e-300)))
    if not worst <= _AGREE:
        return (f"the rewritten step differs from the observer's by {worst:.3g} of the "
                "state's peak in double precision")
    return ""


__all__ = ["Realization", "collapse_affine", "delta_realization"]
