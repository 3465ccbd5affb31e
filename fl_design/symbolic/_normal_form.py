"""Relative degree, normal form and zero dynamics of a SISO plant, by Lie derivatives in SymPy.

For ``x' = f(x, u)``, ``y = h(x)`` the output derivatives are computed along ``f`` with the input
held constant: ``y^(0) = h``, ``y^(i) = (d y^(i-1)/dx) f(x, u)``. The relative degree ``rho`` is
the first ``i`` with ``d y^(i)/du`` not identically zero, and the lumped term of the method is
``sigma = y^(rho) = a + b u`` with ``b = d sigma/du`` and ``a = sigma - b u``. The input may enter
non-affinely: then ``b`` (and ``a``) depend on ``u``, and ``sigma`` is still the true
``y^(rho)``. States, input and parameters are treated as real numbers (``d|x|/dx = sign(x)``);
``DiracDelta`` terms from differentiating ``sign``/``Heaviside`` are dropped (the derivative almost
everywhere).

``b`` is bounded over the plant's region and input range by :func:`b_bounds` (a dense grid
plus bounded local refinement; see :meth:`fl_design.Plant.b_bounds`).

The zero dynamics (``n > rho``) are judged on the linearization ``(A, B, C)`` at the operating
point: their eigenvalues are the invariant zeros of ``(A, B, C)``, computed as the eigenvalues of
``A - B (C A^(rho-1) B)^-1 C A^rho`` restricted to the kernel of ``[C; CA; ...; CA^(rho-1)]``.
This is a local test: hyperbolic eigenvalues in the open left half-plane give local exponential
stability of the zero dynamics; an eigenvalue with real part ``>= -1e-9 max(1, |A|)`` makes
``minimum_phase`` False (unstable, or marginal and so not certified by the linearization).

Examples
--------
>>> import sympy as sp
>>> import fl_design as fl
>>> x1, x2, w, u = sp.symbols("x1 x2 w u")
>>> plant = fl.Plant.from_ode([x1, x2, w], u, [x2, u, w + x1], x1)
>>> nf = plant.normal_form()
>>> nf.rho, nf.b, nf.minimum_phase
(2, 1, False)
>>> nf.zero_dynamics_eigenvalues.real.round(6).tolist()
[1.0]
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import sympy as sp

from ..errors import ComputationError, ParameterError, RelativeDegreeError
from ._bridge import to_casadi
from ._budget import time_budget
from ._enclosure import enclose
from ._lie import lie_derivative
from ._probe import _check_b_scale, _identically_zero, _negligible_note, _Probe
from ._tidy import _drop_dirac, _real_maps, tidy


# --- symbolic helpers --------------------------------------------------------------------------
def _lie_step(y: sp.Expr, states, rhs) -> sp.Expr:
    return _drop_dirac(lie_derivative(y, states, rhs))


@dataclass(frozen=True)
class LieChain:
    """Output derivatives ``y, y', ..., y^(rho)`` (original symbols) and ``b = d y^(rho)/du``."""

    rho: int
    derivatives: tuple
    b: sp.Expr
    notes: tuple = ()  # warnings of the derivation, emitted again when read from the cache


def lie_chain(plant) -> LieChain:
    """Compute the relative degree by Lie derivatives (see the module docstring).

    Raises RelativeDegreeError if the input does not appear up to ``y^(n)`` or if ``b`` vanishes
    at the operating point ``(x_op, u_eq)``; DerivationTimeoutError past the time budget
    (:func:`~fl_design.symbolic._budget.time_budget`).
    """
    with time_budget(f"the relative degree of plant {plant.name!r}"):
        return _lie_chain(plant)


def _lie_chain(plant) -> LieChain:
    fwd, back = _real_maps([*plant.states, plant.input, *plant.params])
    states = [fwd.get(s, s) for s in plant.states]
    u = fwd.get(plant.input, plant.input)
    floats = {f: sp.Dummy(f"c{k}", real=True) for k, f in enumerate(sorted(
        set().union(*(e.atoms(sp.Float) for e in (*plant.rhs, plant.output))), key=float))}
    numbers = {d: f for f, d in floats.items()}  # the plant's floats as symbols while deriving
    rhs = [e.xreplace(fwd).xreplace(floats) for e in plant.rhs]
    y = plant.output.xreplace(fwd).xreplace(floats)
    probe = _Probe(plant)
    derivs = [y.xreplace(numbers)]
    for i in range(1, plant.n + 1):
        y = _lie_step(y, states, rhs)
        b = sp.diff(y, u)
        if _identically_zero(b.xreplace(back), probe, numbers):
            y = y.subs(u, 0)  # u only in terms that cancel
            derivs.append(y.xreplace(numbers))
            continue
        y, b = y.xreplace(numbers), b.xreplace(numbers)
        note = _negligible_note(plant, i, b.xreplace(back), y.xreplace(back), probe)
        derivs.append(y)
        out = tuple(tidy(d.xreplace(back)) for d in derivs)
        b = tidy(_drop_dirac(b).xreplace(back))
        _check_b_at_operating_point(plant, i, b, probe)
        return LieChain(rho=i, derivatives=out, b=b, notes=(note,) if note else ())
    raise RelativeDegreeError(
        f"the input {plant.input} does not appear in y, y', ..., y^({plant.n}) of plant "
        f"{plant.name!r} (n = {plant.n}): the relative degree is not defined; the output "
        f"{plant.output} cannot be steered by the input"
    )


def _check_b_at_operating_point(plant, rho: int, b: sp.Expr, probe: _Probe) -> None:
    """RelativeDegreeError unless b != 0 at the operating point, decided by a rigorous interval
    enclosure of b there (:func:`~fl_design.symbolic._enclosure.enclose`: ``1 + 40 u**39`` is
    ``[1, 1]`` at ``u = 0``, whatever its size elsewhere); the relative test against b's size at
    probe points only for an expression the enclosure does not support."""
    point = {**dict(zip(plant.states, plant.x_op.tolist())), plant.input: plant.u_eq}
    value = complex(b.subs(plant.params).subs(point).evalf()) if b.free_symbols else complex(b)
    box = {s: (float(v), float(v)) for s, v in point.items()}
    box.update({k: (float(v), float(v)) for k, v in plant.params.items()})
    enclosure = enclose(b, box)
    vanishes = _check_b_scale(value, b, probe) if enclosure is None else \
        enclosure[0] <= 0.0 <= enclosure[1]
    if vanishes:
        where = ", ".join(f"{s}={v:g}" for s, v in point.items())
        raise RelativeDegreeError(
            f"the input coefficient b = d y^({rho})/d{plant.input} = {b} of plant {plant.name!r} "
            f"is {value.real:.3g} at the operating point ({where}): the relative degree is not "
            "defined there; choose an operating point (or output) where b != 0"
        )


# --- bounds of b over the region ------------------------------------------------------------
def _box(plant, variables: list) -> list[tuple[float, float]]:
    box = []
    for v in variables:
        if v == plant.input:
            if plant.input_range is None:
                raise ParameterError(
                    f"b depends on the input {v} but plant {plant.name!r} has no input_range; "
                    "pass input_range=(lo, hi)"
                )
            box.append(plant.input_range)
        else:
            rng = (plant.region or {}).get(v)
            if rng is None:
                raise ParameterError(
                    f"b depends on the state {v} but the region of plant {plant.name!r} gives no "
                    f"range for it; pass region={{{v.name!r}: (lo, hi), ...}}"
                )
            box.append(rng)
    return box


def _grid(box, anchors) -> np.ndarray:
    k = len(box)
    m = min(2001, int(np.floor(200_000 ** (1.0 / k))))
    if m >= 5:
        axes = []
        for (lo, hi), a in zip(box, anchors):
            extra = [p for p in (0.0, a) if lo < p < hi]
            axes.append(np.unique(np.concatenate([np.linspace(lo, hi, m), extra])))
        return np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")])
    lo, hi = np.array(box).T
    from scipy.stats import qmc  # 0.9 s to import: only when b-bounds are computed

    pts = qmc.Sobol(k, scramble=True, seed=0).random_base2(16)
    return qmc.scale(pts, lo, hi).T


def b_bounds(plant, *, allow_sign_change: bool = False) -> tuple[float, float]:
    """``(b_min, b_max)`` over the plant's region x input range (see :meth:`fl_design.Plant.b_bounds`)."""
    b = plant._lie_chain().b.subs(plant.params)
    variables = [s for s in (*plant.states, plant.input) if s in b.free_symbols]
    if not variables:
        val = float(b)
        bounds = (val, val)
    else:
        box = _box(plant, variables)
        ops = {**dict(zip(plant.states, plant.x_op.tolist())), plant.input: plant.u_eq}
        fn = sp.lambdify(variables, b, modules="numpy")
        pts = _grid(box, [ops[v] for v in variables])
        with np.errstate(all="ignore"):
            vals = np.broadcast_to(np.asarray(fn(*pts), dtype=float), pts.shape[1:])
        if not np.all(np.isfinite(vals)):
            bad = pts[:, np.argmin(np.isfinite(vals))]
            raise ComputationError(f"b = {b} is not finite on the region, e.g. at "
                                   f"{dict(zip(map(str, variables), bad.tolist()))}")
        bounds = (_refine(fn, pts, vals, box, +1.0), _refine(fn, pts, vals, box, -1.0))
    lo, hi = bounds
    if not allow_sign_change and lo <= 0.0 <= hi:
        raise RelativeDegreeError(
            f"b = {plant._lie_chain().b} of plant {plant.name!r} ranges over [{lo:.6g}, {hi:.6g}] on "
            "the region: it changes sign or vanishes, but the method needs a known sign of b; "
            "shrink the region/input_range (or pass allow_sign_change=True to get the bounds)"
        )
    return bounds


def _refine(fn, pts, vals, box, sign: float) -> float:
    """min of sign*b (sign=+1 minimum, -1 maximum) from the grid, polished by L-BFGS-B."""
    import scipy.optimize  # lazy: 0.3-0.8 s to import, needed only when bounds are computed

    best = float(np.min(sign * vals))
    order = np.argsort(sign * vals)[:4]

    def obj(z):
        with np.errstate(all="ignore"):
            v = sign * float(fn(*z))
        return v if np.isfinite(v) else np.inf

    for i in order:
        res = scipy.optimize.minimize(obj, pts[:, i], method="L-BFGS-B", bounds=box)
        if np.isfinite(res.fun):
            best = min(best, float(res.fun))
    return sign * best


# --- zero dynamics ------------------------------------------------------------------------------
def zero_dynamics_matrix(A: np.ndarray, B: np.ndarray, C: np.ndarray, rho: int) -> np.ndarray:
    """Linear zero-dynamics matrix ``N^T (A - B C A^rho / (C A^(rho-1) B)) N``, ``N = ker O_rho``.

    Its eigenvalues are the invariant zeros of ``(A, B, C)`` when ``C A^(rho-1) B != 0``.
    """
    n = A.shape[0]
    rows = [C.reshape(1, n)]
    for _ in range(rho):
        rows.append(rows[-1] @ A)
    obs = np.vstack(rows[:rho])
    beta = float((rows[rho - 1] @ B.reshape(n, 1)).item())
    a_cl = A - B.reshape(n, 1) @ rows[rho] / beta
    import scipy.linalg  # lazy, as above

    null = scipy.linalg.null_space(obs)
    return null.T @ a_cl @ null


@dataclass(frozen=True)
class InternalDynamics:
    """Internal dynamics ``eta' = f0(eta, xi[, u])`` with ``eta`` chosen among the original states.

    Parameters
    ----------
    eta : tuple of sympy.Symbol
        The original states kept as internal coordinates.
    xi : tuple of sympy.Symbol
        Symbols ``xi_1..xi_rho`` standing for ``y, y', ..., y^(rho-1)``.
    state_map : dict
        The other states as functions of ``(xi, eta)``.
    rhs : sympy.Matrix
        ``eta'`` in ``(eta, xi)`` (and the input, if ``depends_on_input``).
    depends_on_input : bool
        True if the chosen ``eta`` are not input-free (``eta'`` contains ``u``).
    zero_dynamics : sympy.Matrix or None
        ``eta'`` with ``xi`` held at its operating value and, if needed, the input that keeps
        ``y^(rho) = 0`` (``u = -a/b``, affine input only); None when that input is not explicit.

    Examples
    --------
    >>> import sympy as sp
    >>> import fl_design as fl
    >>> x1, x2, w, u = sp.symbols("x1 x2 w u")
    >>> nf = fl.Plant.from_ode([x1, x2, w], u, [x2, u, -w + x1], x1).normal_form()
    >>> nf.internal_dynamics.rhs
    Matrix([[-w + xi_1]])
    """

    eta: tuple
    xi: tuple
    state_map: dict
    rhs: sp.Matrix
    depends_on_input: bool
    zero_dynamics: sp.Matrix | None


def _xi_symbols(rho: int, taken: set) -> tuple:
    names = [f"xi_{i}" for i in range(1, rho + 1)]
    while any(nm in taken for nm in names):
        names = [nm + "'" for nm in names]
    return tuple(sp.Symbol(nm, real=True) for nm in names)


def internal_dynamics(plant, chain: LieChain, nf_a: sp.Expr) -> tuple[InternalDynamics | None, str]:
    """Symbolic internal dynamics when ``eta`` can be chosen among the states (see NormalForm)."""
    rho, n = chain.rho, plant.n
    if rho == n:
        return None, "no internal dynamics: the relative degree equals the state dimension"
    coords = list(chain.derivatives[:rho])
    jac = sp.Matrix(coords).jacobian(plant.states)
    point = {**dict(zip(plant.states, plant.x_op.tolist())), **plant.params}
    jac0 = np.array(jac.subs(point).evalf(), dtype=float)
    xi = _xi_symbols(rho, {str(s) for s in plant.states} | {str(p) for p in plant.params})
    for keep in itertools.combinations(range(n), n - rho):
        rest = [plant.states[i] for i in range(n) if i not in keep]
        sel = np.zeros((n - rho, n))
        sel[range(n - rho), keep] = 1.0
        if np.linalg.cond(np.vstack([jac0, sel])) > 1e10:
            continue
        if any(sp.Poly(c, *rest).total_degree() > 1 for c in coords if c.is_polynomial(*rest)) or \
                not all(c.is_polynomial(*rest) for c in coords):
            return None, (f"the coordinates {coords} are nonlinear in the states {rest}; no "
                          "closed-form inverse of (xi, eta) -> x was attempted")
        sol = sp.solve([c - x for c, x in zip(coords, xi)], rest, dict=True)
        if len(sol) != 1:
            return None, f"the map (xi, eta) -> x has no unique closed form ({len(sol)} solutions)"
        smap = sol[0]
        eta = tuple(plant.states[i] for i in keep)
        rhs = sp.Matrix([tidy(plant.rhs[i].xreplace(smap)) for i in keep])
        dep = plant.input in rhs.free_symbols
        return InternalDynamics(eta, xi, smap, rhs, dep, _zero_dyn(plant, chain, rhs, xi, smap, nf_a)), ""
    return None, "no subset of the original states completes (xi) to a local diffeomorphism"


def _zero_dyn(plant, chain, rhs, xi, smap, nf_a):
    x_op = dict(zip(plant.states, plant.x_op.tolist()))
    xi_op = {x: sp.Float(float(c.subs(x_op).subs(plant.params))) for x, c in zip(xi, chain.derivatives)}
    out = rhs
    if plant.input in rhs.free_symbols:
        if plant.input in chain.b.free_symbols:
            return None
        u_star = (-nf_a / chain.b).xreplace(smap)
        out = out.subs(plant.input, u_star)
    return out.subs(xi_op).applyfunc(tidy)


# --- the normal form object --------------------------------------------------------------------
@dataclass(frozen=True)
class NormalForm:
    """Normal form data of a plant: ``xi_i' = xi_(i+1)``, ``xi_rho' = sigma = a + b u``.

    Built by :meth:`fl_design.Plant.normal_form`; all expressions are in the plant's original
    states, with its parameters still symbolic (``a_fn``/``b_fn`` have them substituted).
    For an input entering non-affinely, ``b = d sigma/du`` and ``a = sigma - b u`` both depend on
    ``u``; for an affine input ``a = sigma(x, 0)`` and ``b`` are input-free, as in the paper.

    Parameters
    ----------
    rho : int
        Relative degree.
    n : int
        State dimension.
    sigma : sympy.Expr
        ``y^(rho)`` as a function of the states and the input.
    a, b : sympy.Expr
        ``b = d sigma/du``, ``a = sigma - b u``.
    coordinates : tuple of sympy.Expr
        ``xi_i = L_f^(i-1) h``, i = 1..rho.
    a_fn, b_fn : casadi.Function
        ``a(x, u)`` and ``b(x, u)`` with numeric parameters.
    zero_dynamics_eigenvalues : numpy.ndarray
        Eigenvalues of the linearized zero dynamics (the invariant zeros); empty if n == rho.
    minimum_phase : bool
        All of them have real part ``< -1e-9 max(1, |A|)``; True if n == rho.
    internal_dynamics : InternalDynamics or None, optional
        Symbolic ``eta' = f0(eta, xi)`` when ``eta`` can be chosen among the original states
        and the coordinates are linear in the others; otherwise None.
    internal_dynamics_reason : str, optional
        Why ``internal_dynamics`` is None (empty otherwise).
    affine : bool, optional
        True if the input enters affinely (``b`` does not depend on the input).

    Examples
    --------
    >>> import fl_design as fl
    >>> nf = fl.plants.pendulum().normal_form()
    >>> nf.rho, nf.b, nf.minimum_phase
    (2, b, True)
    """

    rho: int
    n: int
    sigma: sp.Expr
    a: sp.Expr
    b: sp.Expr
    coordinates: tuple
    a_fn: ca.Function
    b_fn: ca.Function
    zero_dynamics_eigenvalues: np.ndarray
    minimum_phase: bool
    internal_dynamics: InternalDynamics | None = None
    internal_dynamics_reason: str = field(default="")
    affine: bool = True

    def __post_init__(self):
        if not 1 <= self.rho <= self.n:
            raise RelativeDegreeError(f"rho must be in 1..n={self.n}, got {self.rho}")
        if len(self.coordinates) != self.rho:
            raise RelativeDegreeError(
                f"coordinates must have rho={self.rho} entries, got {len(self.coordinates)}"
            )
        if np.shape(self.zero_dynamics_eigenvalues) != (self.n - self.rho,):
            raise RelativeDegreeError(
                f"zero_dynamics_eigenvalues must have n - rho = {self.n - self.rho} entries, got "
                f"{np.shape(self.zero_dynamics_eigenvalues)}"
            )

    def zero_dynamics_report(self) -> str:
        """Plain-text verdict on the zero dynamics (stable, unstable or marginal, with eigenvalues).

        Examples
        --------
        >>> import fl_design as fl
        >>> print(fl.plants.flexible_joint().normal_form().zero_dynamics_report())
        relative degree 4 = n: no zero dynamics (minimum phase trivially)
        """
        if self.n == self.rho:
            return f"relative degree {self.rho} = n: no zero dynamics (minimum phase trivially)"
        eig = ", ".join(_fmt(z) for z in self.zero_dynamics_eigenvalues)
        if self.minimum_phase:
            verdict = "minimum phase: the linearized zero dynamics are asymptotically stable"
        elif np.any(self.zero_dynamics_eigenvalues.real > 1e-9):
            verdict = "NOT minimum phase: the zero dynamics are UNSTABLE (eigenvalue in the open RHP)"
        else:
            verdict = ("NOT minimum phase (not certified): marginal zero-dynamics eigenvalue on the "
                       "imaginary axis; the linearization cannot decide stability")
        return (f"relative degree {self.rho} < n = {self.n}: {self.n - self.rho} zero-dynamics "
                f"eigenvalue(s) [{eig}]\n{verdict}")

    def __repr__(self) -> str:
        zd = "none" if self.n == self.rho else "[" + ", ".join(
            _fmt(z) for z in self.zero_dynamics_eigenvalues) + "]"
        return (f"NormalForm(rho={self.rho}, n={self.n}, b={self.b}, "
                f"minimum_phase={self.minimum_phase}, zero_dynamics_eigenvalues={zd})")


def _fmt(z: complex) -> str:
    return f"{z.real:.6g}" if abs(z.imag) < 1e-12 else f"{z.real:.6g}{z.imag:+.6g}j"


def derive_normal_form(plant) -> NormalForm:
    """Build the :class:`NormalForm` of ``plant`` (see :meth:`fl_design.Plant.normal_form`)
    within the derivation's time budget (:func:`~fl_design.symbolic._budget.time_budget`)."""
    with time_budget(f"the normal form of plant {plant.name!r}"):
        return _derive_normal_form(plant)


def _derive_normal_form(plant) -> NormalForm:
    chain = plant._lie_chain()
    rho, u = chain.rho, plant.input
    sigma = chain.derivatives[rho]
    b = chain.b
    a = tidy(sigma.subs(u, 0)) if u not in b.free_symbols else tidy(sigma - b * u)
    args = [list(plant.states), [u]]
    names = {"subs": plant.params, "input_names": ["x", "u"]}
    a_fn = to_casadi(a, args, "a", output_name="a", **names)
    b_fn = to_casadi(b, args, "b", output_name="b", **names)
    if rho < plant.n:
        A, B, C, _ = plant.linearization()
        eig = np.linalg.eigvals(zero_dynamics_matrix(A, B, C, rho))
        tol = 1e-9 * max(1.0, float(np.linalg.norm(A)))
        minimum_phase = bool(np.all(eig.real < -tol))
    else:
        eig, minimum_phase = np.zeros(0, dtype=complex), True
    internal, reason = internal_dynamics(plant, chain, a)
    return NormalForm(rho=rho, n=plant.n, sigma=sigma, a=a, b=b,
                      coordinates=tuple(chain.derivatives[:rho]), a_fn=a_fn, b_fn=b_fn,
                      zero_dynamics_eigenvalues=np.sort_complex(np.asarray(eig, dtype=complex)),
                      minimum_phase=minimum_phase, internal_dynamics=internal,
                      internal_dynamics_reason=reason, affine=u not in b.free_symbols)


__all__ = [
    "InternalDynamics",
    "LieChain",
    "NormalForm",
    "derive_normal_form",
    "lie_chain",
    "tidy",
    "zero_dynamics_matrix",
]
