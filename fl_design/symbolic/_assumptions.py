"""Is the plant inside the method's assumptions? One check for ``run``, ``tune`` and ``certify``.

The method (DESIGN.md, "The method") assumes a **minimum-phase** plant (the zero dynamics, left
alone by the controller, are stable) and a **known sign of b** on the region of interest (gamma
takes the sign of b; a ``b`` that vanishes or changes sign makes the dynamic controller push the
wrong way somewhere in the region). :func:`check_assumptions` tests both before any long
computation and raises :class:`~fl_design.errors.AssumptionError` naming the zero-dynamics
eigenvalues, or the point of the region where ``b`` vanishes or takes the other sign, and the
reason. It is cheap: the normal form and the b-range are cached derivations of the plant.

:func:`assumption_failures` returns the same findings as sentences (empty when the plant fits),
for a research override that goes on anyway and says so.

Examples
--------
>>> import sympy as sp
>>> import fl_design as fl
>>> from fl_design.symbolic._assumptions import assumption_failures
>>> w, x1, x2, u = sp.symbols("w x1 x2 u")
>>> nmp = fl.Plant.from_ode([w, x1, x2], u, [w + x1, x2, u], x1)
>>> print(assumption_failures(nmp)[0])
NOT minimum phase: the zero dynamics have the eigenvalue(s) [1] (real part >= 0) at the operating point; ...
>>> assumption_failures(fl.plants.pendulum())
()
"""

from __future__ import annotations

import numpy as np

from ..errors import AssumptionError, ParameterError, RelativeDegreeError

#: Points per variable of b's grid when looking for where it vanishes (at most 4 variables
#: gridded; more are sampled at 4096 quasi-random points).
_GRID = 41


def assumption_failures(plant) -> tuple[str, ...]:
    """The method's assumptions the plant breaks, one sentence each (empty: none).

    Parameters
    ----------
    plant : Plant
        The plant (its operating point, region and input range).

    Returns
    -------
    tuple of str
        ``"NOT minimum phase: ..."`` with the zero-dynamics eigenvalues, and/or ``"b changes
        sign or vanishes ..."`` with the point of the region where it does.

    Examples
    --------
    >>> import fl_design as fl
    >>> assumption_failures(fl.plants.trms_yaw())
    ()
    """
    out = []
    zeros = zero_dynamics_eigenvalues(plant)
    A = plant.linearization()[0]
    if zeros.size and not np.all(zeros.real < -1e-9 * max(1.0, float(np.linalg.norm(A)))):
        eig = ", ".join(_fmt(z) for z in zeros)
        out.append(f"NOT minimum phase: the zero dynamics have the eigenvalue(s) [{eig}] (real "
                   "part >= 0) at the operating point; the method keeps the output on its "
                   "reference while the internal state diverges: it does not apply")
    b = _b_sign_failure(plant)
    if b:
        out.append(b)
    return tuple(out)


def zero_dynamics_eigenvalues(plant) -> np.ndarray:
    """The zero dynamics' eigenvalues at the operating point: the invariant zeros of the
    linearization ``(A, B, C)``, the finite generalized eigenvalues of the Rosenbrock pencil
    ``[[A, B], [C, 0]] - s [[I, 0], [0, 0]]`` (SciPy; no SymPy, so a cached library plant
    stays SymPy-free). The same test as :attr:`fl_design.NormalForm.minimum_phase`.

    Parameters
    ----------
    plant : Plant
        Linearized at its operating point ``(x_op, u_eq)``.

    Returns
    -------
    numpy.ndarray
        ``n - rho`` complex numbers, sorted (empty when ``rho = n``).

    Examples
    --------
    >>> import sympy as sp
    >>> import fl_design as fl
    >>> w, x1, x2, u = sp.symbols("w x1 x2 u")
    >>> p = fl.Plant.from_ode([w, x1, x2], u, [-2 * w + x1, x2, u], x1)
    >>> zero_dynamics_eigenvalues(p).real.tolist()
    [-2.0]
    """
    import scipy.linalg

    A, B, C, _ = plant.linearization()
    n = A.shape[0]
    if plant.relative_degree() >= n:
        return np.zeros(0, dtype=complex)
    M = np.block([[A, B], [C, np.zeros((1, 1))]])
    N = np.zeros_like(M)
    N[:n, :n] = np.eye(n)
    alpha, beta = scipy.linalg.eigvals(M, N, homogeneous_eigvals=True)
    finite = np.abs(beta) > 1e-12 * np.maximum(np.abs(alpha), 1.0)
    return np.sort_complex(alpha[finite] / beta[finite])


def check_assumptions(plant, *, what: str = "the design") -> None:
    """Refuse a plant outside the method's assumptions (see the module), before any work.

    Parameters
    ----------
    plant : Plant
        Its zero dynamics and its ``b`` over the region are checked.
    what : str, optional
        What is refused, for the message (e.g. ``"fl.tune"``, ``"fl-design run"``).

    Raises
    ------
    AssumptionError
        Unstable (or marginal) zero dynamics, or ``b`` vanishing or changing sign on the
        region: the eigenvalues or the point, and the reason.

    Examples
    --------
    >>> import fl_design as fl
    >>> check_assumptions(fl.plants.trms_yaw())  # inside: nothing happens
    """
    failures = assumption_failures(plant)
    if failures:
        raise AssumptionError(f"{what} refused for plant {plant.name!r}, outside the method's "
                              "assumptions: " + "; ".join(failures))


def _b_sign_failure(plant) -> str | None:
    """A sentence when b vanishes or changes sign on region x input range (None: it does not,
    or the plant gives no region/input range to bound it on)."""
    if plant.input_range is None:
        return None
    try:
        lo, hi = plant.b_bounds(allow_sign_change=True)
    except (ParameterError, RelativeDegreeError):
        return None  # b depends on a variable without a range: not bounded here (tune says so)
    if lo * hi > 0:
        return None
    point = _where_b_flips(plant, lo, hi)
    return (f"b = {plant.normal_form().b} vanishes or changes sign on the region (b in "
            f"[{lo:.4g}, {hi:.4g}]; b = {point[1]:.4g} at {point[0]}, against "
            f"{point[2]:.4g} at the operating point): the method needs a known sign of b; "
            "shrink the region or the input range")


def _where_b_flips(plant, lo: float, hi: float) -> tuple[str, float, float]:
    """``(point text, b there, b at the operating point)``: the grid point of region x input
    range where b is farthest on the other side of zero from its operating-point value."""
    fn = plant.casadi().b
    ranges, _ = plant._state_ranges()
    x_op = np.asarray(plant.x_op, dtype=float)
    axes = [(name, r) for name, r in ranges.items() if r is not None]
    axes.append((str(plant.input), tuple(plant.input_range)))
    b_op = float(fn(x_op, plant.u_eq))
    if len(axes) <= 4:
        mesh = np.meshgrid(*[np.linspace(a, b, _GRID) for _, (a, b) in axes], indexing="ij")
        pts = np.stack([m.ravel() for m in mesh], axis=1)
    else:
        rng = np.random.default_rng(0)
        lows = np.array([r[0] for _, r in axes])
        highs = np.array([r[1] for _, r in axes])
        pts = lows + rng.random((4096, len(axes))) * (highs - lows)
    names = list(ranges)
    X = np.tile(x_op, (len(pts), 1))
    for k, (name, _) in enumerate(axes[:-1]):
        X[:, names.index(name)] = pts[:, k]
    import casadi as ca

    vals = np.asarray(fn.map(len(pts))(ca.DM(X.T), ca.DM(pts[:, -1]).T), dtype=float).ravel()
    side = np.sign(b_op) if b_op != 0 else 1.0
    k = int(np.nanargmin(side * vals))
    where = ", ".join(f"{name}={pts[k, i]:.4g}" for i, (name, _) in enumerate(axes))
    return where, float(vals[k]), b_op


def _fmt(z: complex) -> str:
    return f"{z.real:.4g}" if abs(z.imag) < 1e-12 else f"{z.real:.4g}{z.imag:+.4g}j"


__all__ = ["assumption_failures", "check_assumptions", "zero_dynamics_eigenvalues"]
