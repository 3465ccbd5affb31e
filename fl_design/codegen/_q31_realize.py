"""Fewer products for the Q31 step: the observer as a cascade of first-order sections.

A linear observer ``xi' = A xi + B y``, ``xhat = C xi + D y`` (the EHGO) of order ``m`` costs
``m (m + 1)`` products per step in its own coordinates, and the controller ``rho + 1`` more
(``K xhat``). In the coordinates ``w = T xi`` of a cascade of first-order sections,

    w_1' = w_1 + delta_1 (y - w_1),   w_k' = w_k + delta_k (w_(k-1) - w_k),   delta_k = 1 - p_k

(``p_k`` the observer's poles, real), the update costs ``m`` products, every section has unit
gain at rest (``w_k = y0`` for a constant ``y0``: the start is exact) and, for ``0 < delta_k
<= 1``, stays within the range of ``y`` (a convex combination: the interval analysis is
exact). The controller reads ``xhat = C T^-1 w + D y`` only through a few linear functionals
(the error ``xhat_1 - r``, the law ``sum k_i xhat_i + sigmahat``, a clamped estimate):
:func:`collapse_affine` computes each of them once as a sum over ``w, y, r, u, z`` (``m +
4`` products at most) instead of forming every ``xhat_i``.

``T^-1 = ctrb(A, B) ctrb(Abar, Bbar)^-1`` is computed in exact rational arithmetic from the
floating-point ``A, B`` and the poles (a repeated pole: the mean of its computed cluster, which
is exact to rounding where each computed root is off by ``eps^(1/m)``). The realization is
used only if the step it gives agrees with the observer's own in double precision on a random
record within the range (``1e-9`` of the values' scale); otherwise (complex poles, a
non-linear estimator, a mismatch) the step keeps the observer's coordinates, with the reason.

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen import step_design
>>> from fl_design.codegen._q31_realize import cascade_realization
>>> real = cascade_realization(step_design(presets.flexible_joint_design(), "q31"), (-3, 3))
>>> real.name, len(real.delta), round(real.delta[0], 4)
('cascade', 5, 0.1818)
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import casadi as ca
import numpy as np

#: computed poles closer than this (relative to 1 - |p|, at least 1e-9) are one repeated pole
_CLUSTER = 0.02
#: the realization's step against the observer's own, relative to the values' scale
_AGREE = 1e-9
_AFFINE = (ca.OP_ADD, ca.OP_SUB, ca.OP_NEG, ca.OP_TWICE, ca.OP_ASSIGN, ca.OP_MUL)


@dataclass(frozen=True)
class Realization:
    """The core the Q31 program is built from and its observer's coordinates.

    Parameters
    ----------
    name : str
        ``"cascade"`` or ``"direct"`` (the observer's own coordinates).
    core : casadi.Function
        ``(x, y, r) -> (x_next, u)`` with the design's numbers fixed.
    A, B : numpy.ndarray
        The observer's linear update in these coordinates (for its peak-gain boxes).
    T : numpy.ndarray
        ``w = T xi``: an estimator state in these coordinates (identity for ``"direct"``).
    delta : tuple of float
        The sections' ``delta_k`` (empty for ``"direct"``).
    why : str
        Why the cascade was not used (empty when it was).
    """

    name: str
    core: ca.Function
    A: np.ndarray
    B: np.ndarray
    T: np.ndarray
    delta: tuple = ()
    why: str = ""


def affine_estimator(design):
    """``(A, B, C, D)`` of the estimator's update, or None when it is not affine (or holds).

    Parameters
    ----------
    design : Design
        The generated design.

    Returns
    -------
    tuple of numpy.ndarray or None

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import step_design
    >>> from fl_design.codegen._q31_realize import affine_estimator
    >>> A, B, C, D = affine_estimator(step_design(presets.paper_design(), "q31"))
    >>> A.shape, C.shape
    ((3, 3), (3, 3))
    """
    est = design.estimator
    m = int(est.state_size)
    xi, y = ca.SX.sym("xi", m), ca.SX.sym("y")
    xhat, xi_next, ready = est.symbolic_update(xi, y, ca.DM(est.parameter_vector()))
    ready = ca.SX(ready)
    if not (ready.is_constant() and float(ca.DM(ready)) == 1.0):
        return None
    outs = ca.vertcat(xi_next, xhat)
    jac = ca.Function("lin_jac", [xi, y], [ca.jacobian(outs, xi), ca.jacobian(outs, y)])
    if ca.depends_on(ca.jacobian(outs, ca.vertcat(xi, y)), ca.vertcat(xi, y)):
        return None
    J, b = (np.asarray(v, dtype=float) for v in jac(np.zeros(m), 0.0))
    f = ca.Function("f", [xi, y], [outs])
    if np.max(np.abs(np.asarray(f(np.zeros(m), 0.0), dtype=float))) != 0.0:
        return None  # an offset: not linear
    return J[:m], b[:m].ravel(), J[m:], b[m:].ravel()


def _real_poles(A):
    """The eigenvalues of ``A``, real, repeated ones as the mean of their cluster; None when
    a pair is complex beyond the cluster's spread."""
    ev = np.linalg.eigvals(A)
    order = np.argsort(ev.real)
    ev = ev[order]
    groups, cur = [], [ev[0]]
    for v in ev[1:]:
        ref = np.mean(cur)
        if abs(v - ref) <= _CLUSTER * max(1.0 - abs(ref), 1e-9):
            cur.append(v)
        else:
            groups.append(cur)
            cur = [v]
    groups.append(cur)
    poles = []
    for g in groups:
        mean = complex(np.mean(g))
        if abs(mean.imag) > 1e-12 * max(1.0, abs(mean)):
            return None
        poles += [mean.real] * len(g)
    return poles


def _frac_matrix(M):
    return [[Fraction(float(v)) for v in row] for row in np.atleast_2d(M)]


def _ctrb(A, b):
    """Columns ``b, A b, ..., A^(m-1) b`` (exact)."""
    m = len(b)
    cols, v = [], list(b)
    for _ in range(m):
        cols.append(v)
        v = [sum(A[i][j] * v[j] for j in range(m)) for i in range(m)]
    return [[cols[j][i] for j in range(m)] for i in range(m)]


def _solve_right(X, M):
    """``X M^-1`` (exact, Gauss-Jordan on ``M^T``)."""
    m = len(M)
    # (X M^-1)^T = M^-T X^T: solve M^T Z = X^T
    aug = [[M[j][i] for j in range(m)] + [X[r][i] for r in range(len(X))] for i in range(m)]
    for c in range(m):
        piv = next((r for r in range(c, m) if aug[r][c] != 0), None)
        if piv is None:
            raise ZeroDivisionError("singular")
        aug[c], aug[piv] = aug[piv], aug[c]
        inv = 1 / aug[c][c]
        aug[c] = [v * inv for v in aug[c]]
        for r in range(m):
            if r != c and aug[r][c] != 0:
                f = aug[r][c]
                aug[r] = [a - f * b for a, b in zip(aug[r], aug[c])]
    Z = [row[m:] for row in aug]  # m x len(X)
    return [[Z[i][r] for i in range(m)] for r in range(len(X))]


def _cascade_matrices(delta):
    m = len(delta)
    A = np.zeros((m, m))
    for k, d in enumerate(delta):
        A[k, k] = 1.0 - d
        if k > 0:
            A[k, k - 1] = d
    B = np.zeros(m)
    B[0] = delta[0]
    return A, B


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
    cur, need, aff = {}, set(), {}
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


def cascade_realization(design, y_range, fixed_core=None) -> Realization:
    """The step of ``design`` with its observer as a cascade of first-order sections.

    Parameters
    ----------
    design : Design
        The generated design (after :func:`~fl_design.codegen.step_design`).
    y_range : (float, float)
        The range of ``y`` and ``r`` (the agreement check runs within it).
    fixed_core : casadi.Function, optional
        ``(x, y, r) -> (x_next, u)`` in the observer's own coordinates (default: built here).

    Returns
    -------
    Realization
        ``name == "direct"`` (with ``why``) when the cascade does not apply.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import step_design
    >>> from fl_design.codegen._q31_realize import cascade_realization
    >>> cascade_realization(step_design(presets.paper_design(), "q31"), (-10, 10)).name
    'cascade'
    """
    from ._q31 import _fixed_core, _linear_maps

    f0 = _fixed_core(design) if fixed_core is None else fixed_core
    m = int(design.estimator.state_size)

    def direct(why):
        A, B = _linear_maps(design)
        return Realization("direct", f0, A, B, np.eye(m), (), why)

    lin = affine_estimator(design)
    if lin is None:
        return direct("the estimator is not linear")
    A, B, _, _ = lin
    poles = _real_poles(A)
    if poles is None:
        return direct("the observer has complex poles")
    delta = tuple(1.0 - p for p in sorted(poles, reverse=True))
    if any(d <= 0.0 for d in delta):
        return direct("a pole at or beyond 1")
    Ab, Bb = _cascade_matrices(delta)
    try:
        Tinv = _solve_right(_ctrb(_frac_matrix(A), [Fraction(float(v)) for v in B]),
                            _ctrb(_frac_matrix(Ab), [Fraction(float(v)) for v in Bb]))
    except ZeroDivisionError:
        return direct("the observer is not controllable from y")
    Tinv = np.array([[float(v) for v in row] for row in Tinv])
    s = ca.SX.sym("s", m + 4)
    xi = ca.mtimes(ca.DM(Tinv), s[:m])
    x_next, _ = f0(ca.vertcat(xi, s[m], s[m + 1]), s[m + 2], s[m + 3])
    g = collapse_affine(ca.Function("g", [s], [x_next[m:m + 2]]))
    x, y, r = ca.SX.sym("x", m + 2), ca.SX.sym("y"), ca.SX.sym("r")
    prev = [y] + [x[k] for k in range(m - 1)]
    w_next = [x[k] + ca.SX(delta[k]) * (prev[k] - x[k]) for k in range(m)]
    uz = g(ca.vertcat(x[:m], x[m], x[m + 1], y, r))
    from ._q31_factor import factor_constants

    core = factor_constants(ca.Function("q31_core", [x, y, r],
                                        [ca.vertcat(*w_next, uz[0], uz[1]), uz[0]]))
    T = np.linalg.inv(Tinv)
    why = _disagreement(design, f0, core, T, y_range)
    if why:
        return direct(why)
    return Realization("cascade", core, Ab, Bb, T, delta, "")


def _controller_of(design, lin_xhat, leaves_n):
    """``g(s) -> (u, z)`` with ``s = [leaves..., y, r, u_prev, z_prev]``: the design's law fed
    ``xhat = lin_xhat(s)`` (affine), collapsed (:func:`collapse_affine`)."""
    s = ca.SX.sym("s", leaves_n + 4)
    y, r, u_prev, z_prev = (s[leaves_n + i] for i in range(4))
    ctrl = design.controller
    u, z, _ = ctrl.symbolic_law(lin_xhat(s), r, u_prev, z_prev, 1, ctrl.gamma, design.T)
    return collapse_affine(ca.Function("g", [s], [ca.vertcat(u, z)]))


def _delta_recursion(design):
    """The EHGO's delta update ``g = G e`` as its recursion, or None.

    ``G = (I - beta F)^-1 alpha F`` (``beta = theta alpha``, ``F`` the companion matrix of the
    coefficients ``c``) solves as ``a_i = e_i + beta a_(i+1)``, ``t_0 = a_0 / (1 - b_0)``
    (``b_i = beta b_(i+1) - beta c_i``), ``g_i = alpha a_(i+1) + alpha (b_(i+1) - c_i) t_0``
    (``a_n = b_n = 0``), and ``xhat = D^-1 (xi + theta g)`` is ``D^-1_0 (t_0 + y)``, ``D^-1_i
    (a_i + b_i t_0)``: ``3 n - 1`` products instead of ``n^2``, fewer when ``alpha`` or
    ``beta`` is a power of two. Returns ``(alpha, beta, kappa, gamma, b, dinv)`` when ``G``
    (as the estimator computes it) is this within ``1e-12``."""
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
    return alpha, beta, kappa, gam, b, [float(v) for v in est.unscaling], theta


def delta_realization(design, y_range, fixed_core=None) -> Realization:
    """The step of ``design`` with its EHGO's delta update as a recursion (same coordinates).

    See :func:`_delta_recursion`; the controller reads the estimates through the sums
    :func:`collapse_affine` prints. The observer keeps its coordinates (its state, start and
    boxes are the delta realization's own); only the order of the operations changes.

    Parameters
    ----------
    design : Design
        The generated design (after :func:`~fl_design.codegen.step_design`).
    y_range : (float, float)
        The range of ``y`` and ``r`` (the agreement check runs within it).
    fixed_core : casadi.Function, optional
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
    from ._q31 import _fixed_core, _linear_maps
    from ._q31_factor import factor_constants

    f0 = _fixed_core(design) if fixed_core is None else fixed_core
    m = int(design.estimator.state_size)
    A, B = _linear_maps(design)
    rec = _delta_recursion(design)
    if rec is None:
        return Realization("direct", f0, A, B, np.eye(m), (), "not an EHGO delta update of "
                           "the bilinear or Euler methods")
    alpha, beta, kappa, gam, b, dinv, theta = rec

    def lin_xhat(s):  # s = [a_1 .. a_(m-1), t_0, y, ...]
        t0, y = s[m - 1], s[m]
        return ca.vertcat(dinv[0] * (t0 + y) if theta else dinv[0] * (t0 + y),
                          *[dinv[i] * (s[i - 1] + b[i] * t0) for i in range(1, m)])

    g = _controller_of(design, lin_xhat, m)
    x, y, r = ca.SX.sym("x", m + 2), ca.SX.sym("y"), ca.SX.sym("r")
    e = [x[0] - y] + [x[i] for i in range(1, m)]
    a = [None] * (m + 1)
    a[m - 1] = e[m - 1]
    for i in range(m - 2, -1, -1):
        a[i] = e[i] + ca.SX(beta) * a[i + 1] if beta else e[i]
    t0 = ca.SX(kappa) * a[0]
    xi_next = [x[i] + (ca.SX(alpha) * a[i + 1] if i + 1 < m else 0) + ca.SX(gam[i]) * t0
               for i in range(m)]
    uz = g(ca.vertcat(*a[1:m], t0, y, r, x[m], x[m + 1]))
    core = factor_constants(ca.Function("q31_core", [x, y, r],
                                        [ca.vertcat(*xi_next, uz[0], uz[1]), uz[0]]))
    why = _disagreement(design, f0, core, np.eye(m), y_range)
    if why:
        return Realization("direct", f0, A, B, np.eye(m), (), why)
    return Realization("recursion", core, A, B, np.eye(m), (), "")


def _disagreement(design, f0, f1, T, y_range, n: int = 400, seed: int = 0) -> str:
    """Empty when the two cores give the same state (``f1``'s in coordinates ``T``: within
    ``_AGREE`` of each entry's peak) on a random record within ``y_range`` from the rest
    state; else the reason."""
    lo, hi = (float(v) for v in y_range)
    rng = np.random.default_rng(seed)
    m = int(design.estimator.state_size)
    y0 = 0.5 * (lo + hi)
    xi = np.asarray(design.estimator.initial_state(y0=y0), dtype=float).ravel()
    u0 = float(np.clip(0.0, *design.controller.u_range))
    x0 = np.concatenate([xi, [u0, 0.0]])
    x1 = np.concatenate([T @ xi, [u0, 0.0]])
    ys = np.clip(y0 + np.cumsum(rng.normal(0.0, 0.02 * (hi - lo), n)), lo, hi)
    rs = np.where(np.arange(n) < n // 2, y0, lo + 0.7 * (hi - lo))
    worst = 0.0
    run = [np.concatenate([T @ x0[:m], x0[m:]])]
    x = x0
    for yk, rk in zip(ys, rs):  # the scale of each entry: its peak on the record
        x = np.asarray(f0(x, yk, rk)[0], dtype=float).ravel()
        run.append(np.concatenate([T @ x[:m], x[m:]]))
    scales = np.maximum(np.max(np.abs(run), axis=0), 1e-300)
    for yk, rk in zip(ys, rs):
        a, _ = f0(x0, yk, rk)
        b, _ = f1(x1, yk, rk)
        x0, x1 = np.asarray(a, dtype=float).ravel(), np.asarray(b, dtype=float).ravel()
        mapped = np.concatenate([T @ x0[:m], x0[m:]])
        worst = max(worst, float(np.max(np.abs(mapped - x1) / scales)))
    if not worst <= _AGREE:
        return (f"the rewritten step differs from the observer's by {worst:.3g} of the "
                "state's scale in double precision")
    return ""


__all__ = ["Realization", "affine_estimator", "cascade_realization", "collapse_affine",
           "delta_realization"]
