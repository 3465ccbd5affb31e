"""Invariant ellipsoids of the sampled loop with its input limits, estimate clamps and noise.

**The loop with its nonlinear channels.** In deviation coordinates ``X`` (plant ``x - x_eq``,
observer, ``u - u_eq``, ``z``; the coordinates of :class:`._surrogate.SurrogateLoop`) one
sample of the loop is, for every plant of the LDI of :mod:`._ldi` (``d sigma/d xi`` in a box,
``b`` in its range, both varying in time)::

    X+ = M(Psi) X + B(Psi) psi + E(Psi) n,      Psi in the box of sample maps

where ``n`` is the sensor noise and ``psi`` the dead-zones ``dz(s) = s - clip(s)`` of the
clamped estimates ``s_i = xhat_i`` (``1 <= i <= rho``) and of the saturated input's argument
``nu = u_(k-1) + gamma (v - sigmahat)``: a clamp removes ``psi_i`` from ``xhat_i``, which adds
``gamma k_i psi_i`` to ``nu`` (``gamma psi`` for ``sigmahat``), and ``u_k = nu - psi_u``. The
rows ``K`` (``s = K X + k_n n``) and the matrices come from the design's own Jacobians and the
observer's output matrices; nothing of the step is re-implemented.

**Multipliers (generalized sector condition, Gomes da Silva & Tarbouriech 2005).** For a
dead-zone with room ``[lo, hi]`` (``lo < 0 < hi``), ``dz(s) (dz(s) - w) <= 0`` whenever
``lo <= s - w <= hi``, for any ``w``. With ``w_j = G_j X + (H psi)_j`` (``H`` carries the
clamps into ``nu``) and the ellipsoid ``E = {V(X) = X^T P X <= c}`` inside ``|(K_j - G_j) X|
<= l_j - |k_n,j| nbar`` (``l_j = min(-lo, hi)``), the S-procedure with diagonal ``S > 0``
asks, in the delta form ``X+ = X + T (D X + Bt psi + Et n)`` (``D = (M - I)/T``), at every
corner of the box (the form is convex in ``Psi``, so the corners suffice)::

    [[P D + D^T P + kappa P,  P Bt + G^T S,        P Et],
     [.,                      S H + H^T S - 2 S,   0   ],    + T R^T P R  <=  0,
     [.,                      .,                   -mu ]]       R = [D, Bt, Et]

i.e. ``V(X+) <= (1 - T kappa) V(X) + T mu n^2`` on ``E``. With ``mu nbar^2 <= kappa c`` the
ellipsoid is invariant; without noise ``V`` contracts every sample (exponential convergence),
with noise the loop enters ``V <= mu nbar^2 / kappa``. Saturation and clamps may be active
inside ``E``: the certified set reaches beyond the saturation-free one of
:class:`._ldi.CoveredSet`.

**Solution.** ``P`` is fixed (the LDI certificate's, or one chosen to cover the start: the
joint problem in ``(P, S, G)`` is bilinear); in the coordinates where ``P = I`` the corner
conditions are LMIs in ``(S, Z = S G, mu)`` and the validity region is a second-order cone in
``(s_j, Z_j)`` for a given level: :func:`solve_ellipsoid` builds that SDP once per ``P``
(:func:`._sdp_sector.ellipsoid_program`, Clarabel called directly) and searches the level
(``beta = c^-1/2`` enters only the cones' rows), each level solved at most once.

**Re-check.** :func:`recheck` rebuilds every matrix in NumPy from ``P, c, S, G, mu`` and asks
``lambda_max < -tol ||.||_F`` of each corner's form (the SDP was solved with slack: ``2 kappa``
for ``kappa``, ``1.9 S`` for ``2 S``, ``mu / 1.1`` for ``mu``), ``c (P^-1)_ii <= room_i^2``,
``c (K_j - G_j) P^-1 (K_j - G_j)^T <= (l_j - |k_n,j| nbar)^2`` and ``mu nbar^2 <= kappa c``,
each with the margin :data:`RECHECK_MARGIN`.

Examples
--------
>>> import fl_design as fl
>>> ch = loop_channels(fl.presets.paper_design(), (3.6, 6.8), None)
>>> ch.names, ch.psi_names
(('x_1', 'x_2', 'xi_0', 'xi_1', 'xi_2', 'u', 'z'), ('clamp xhat_2', 'saturation u'))
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..errors import ParameterError

#: Relative margin every re-checked inequality must clear: 1000 x the rounding of forming
#: and factoring the matrices (~n eps ||A|| ~ 1e-14 ||A||).
RECHECK_MARGIN = 1e-11


@dataclass(frozen=True)
class LoopChannels:
    """The sampled loop's matrices with its nonlinear channels (see the module docstring).

    Parameters
    ----------
    Ms, Bs, Es : numpy.ndarray
        Per corner of the sample-map box: ``(k, n, n)``, ``(k, n, m)``, ``(k, n)``.
    K : numpy.ndarray
        ``(m, n)`` rows of the dead-zones' arguments.
    kn : numpy.ndarray
        ``(m,)`` noise coefficient of each argument.
    H : numpy.ndarray
        ``(m, m)``: the clamps' dead-zones inside the input's argument.
    low, high : numpy.ndarray
        ``(m,)`` room of each argument about the equilibrium (``low < 0 < high``).
    names, psi_names : tuple of str
        Loop coordinates and channels.
    T : float
        Sampling time.
    model : str
        How the sample maps were enclosed.
    """

    Ms: np.ndarray
    Bs: np.ndarray
    Es: np.ndarray
    K: np.ndarray
    kn: np.ndarray
    H: np.ndarray
    low: np.ndarray
    high: np.ndarray
    names: tuple
    psi_names: tuple
    T: float
    model: str

    @property
    def room(self) -> np.ndarray:
        """Symmetric room ``min(-low, high)`` of each argument."""
        return np.minimum(-self.low, self.high)


def _psi_box(L, eps, gamma):
    """Corners of an entrywise box holding every sample map ``Psi`` of the LDI, and its words."""
    from ._ldi import _box_corners, _metzler_box, _remainder_bound, _vertices
    from ._surrogate import chain_matrices

    rho, T = L.loop.rho, L.T
    Xs = []
    for a_row, b in _vertices(L):
        X = chain_matrices(rho, a_row)
        X[:, rho] *= b
        Xs.append(X)
    Xs = np.stack(Xs)
    box = _metzler_box(Xs, T)
    if box is not None:
        lo, hi = box
        words = "interval ZOH model (Metzler comparison, exact enclosure)"
    else:
        Xc, Rbar = _remainder_bound(Xs, T)
        Ec = scipy.linalg.expm(T * Xc)
        maps = np.stack([Ec + T * (X - Xc) for X in Xs])
        pad = Rbar + 8.0 * np.finfo(float).eps * np.abs(maps).max(axis=0)
        lo, hi = maps.min(axis=0) - pad, maps.max(axis=0) + pad
        words = "box hull of the first-order model expm(T X_c) + T (X - X_c) +- remainder"
    n_var = int(np.count_nonzero(hi > lo))
    if n_var > 10:
        raise ParameterError(f"the sample-map box has {n_var} varying entries (at most 10: "
                             f"2^10 corners); narrow the slope box")
    out, _ = _box_corners(lo, hi)
    return out, f"{words}, {n_var} varying entries, {len(out)} corners"


def loop_channels(design, b_bounds, a_jacobian_bounds, *, u_eq: float = 0.0) -> LoopChannels:
    """The loop's corner matrices, dead-zone rows and noise columns (module docstring).

    Parameters
    ----------
    design : Design
        An EHGO design; its clamps (on ``xhat_2 .. sigmahat``) and input limits are channels.
    b_bounds : (float, float)
        Range of ``b`` (positive).
    a_jacobian_bounds : sequence of (float, float) or None
        Box of ``d sigma / d xi_i`` (None: ``a = 0``).
    u_eq : float, optional
        Equilibrium input (the limits' room is taken about it).

    Returns
    -------
    LoopChannels

    Raises
    ------
    ParameterError
        A clamp on ``xhat_1``, a negative ``b``, limits not containing ``u_eq`` inside.

    Examples
    --------
    >>> import fl_design as fl
    >>> ch = loop_channels(fl.presets.pendulum_design(), (1.0, 1.0), [(-9.81, -9.0), (-0.5, -0.5)])
    >>> ch.psi_names, ch.Ms.shape[1:]
    ((), (6, 6))
    """
    from ._certify import _Loop

    L = _Loop(design, b_bounds, a_jacobian_bounds, 2, 1)
    if L.sign < 0:
        raise ParameterError("the sector certificate handles b > 0 only (gamma > 0), got "
                             f"b in {tuple(b_bounds)}")
    eps, gamma = float(design.estimator.eps), float(design.controller.gamma)
    loop, rho, ctrl = L.loop, design.rho, design.controller
    est = design.estimator
    u_row = loop.input_row(eps, gamma)
    nfull = u_row.size
    lay = design.state_layout
    i_u = rho + lay["u"].start
    mats = est.matrices
    Cd, Dd = np.asarray(mats[2], float), np.asarray(mats[3], float).ravel()
    unsc = est.unscaling
    rows, kn, lows, highs, nu_coef, names = [], [], [], [], [], []
    for i, lim in enumerate(ctrl.estimate_ranges):
        if lim is None:
            continue
        if i == 0:
            raise ParameterError("a clamp on xhat_1 (the output estimate) is not covered by the "
                                 "sector certificate: it changes the integrator and the error")
        row = np.zeros(nfull)
        row[0] = unsc[i] * Dd[i]
        row[rho:rho + est.state_size] = unsc[i] * Cd[i]
        rows.append(row)
        kn.append(unsc[i] * Dd[i])
        lows.append(float(lim[0]))
        highs.append(float(lim[1]))
        nu_coef.append(gamma * (ctrl.gains[i] if i < rho else 1.0))
        names.append(f"clamp xhat_{i + 1}" if i < rho else "clamp sigmahat")
    m_c = len(rows)
    if ctrl.u_range is not None:
        lo, hi = ctrl.u_range
        if not lo < u_eq < hi:
            raise ParameterError(f"the input limits {ctrl.u_range} do not contain the "
                                 f"equilibrium input u_eq = {u_eq:g} inside")
        rows.append(u_row.copy())
        kn.append(float(u_row[0]))
        lows.append(lo - u_eq)
        highs.append(hi - u_eq)
        names.append("saturation u")
    m = len(rows)
    H = np.zeros((m, m))
    if ctrl.u_range is not None:
        H[m - 1, :m_c] = nu_coef
    # effect of each dead-zone on u_k: +gamma k_i for a clamp, -1 for the saturation
    du = np.array(nu_coef + ([-1.0] if ctrl.u_range is not None else []))
    keep = loop.keep
    Ms, Bs, Es = [], [], []
    maps, model = _psi_box(L, eps, gamma)
    for Psi in maps:
        M0, M1 = loop.assemble(Psi[:rho, :rho], Psi[:rho, rho], u_row, eps, gamma)
        M = M0 + M1
        bcol = np.zeros(nfull)
        bcol[:rho] = Psi[:rho, rho]
        bcol[i_u] = 1.0
        bcol = bcol[keep]
        E = M[:, 0].copy()
        E[:rho] -= Psi[:rho, 0]
        Ms.append(M)
        Bs.append(np.outer(bcol, du) if m else np.zeros((len(keep), 0)))
        Es.append(E)
    K = np.array(rows).reshape(m, nfull)[:, keep]
    return LoopChannels(np.stack(Ms), np.stack(Bs), np.stack(Es), K, np.array(kn, float), H,
                        np.array(lows, float), np.array(highs, float),
                        tuple(loop.names[i] for i in keep), tuple(names), float(L.T), model)


@dataclass(frozen=True)
class Ellipsoid:
    """A re-checked invariant ellipsoid ``V(X) = X^T P X <= level`` of :func:`solve_ellipsoid`.

    Parameters
    ----------
    P : numpy.ndarray
        ``V``'s matrix (loop coordinates).
    level : float
        The certified sublevel.
    kappa : float
        ``V(X+) <= (1 - T kappa) V(X) + T mu n^2`` on the ellipsoid.
    mu : float
        Noise gain (0 without noise).
    noise_bound : float
        Noise peak covered.
    worst : float
        The re-check's worst relative value (< 0: every inequality holds with margin).
    """

    P: np.ndarray
    level: float
    kappa: float
    mu: float
    noise_bound: float
    worst: float

    def value(self, X) -> float:
        """``V(X) = X^T P X``."""
        X = np.asarray(X, float)
        return float(X @ self.P @ X)

    def ultimate_level(self) -> float:
        """The level ``mu nbar^2 / kappa`` the loop enters (0 without noise)."""
        return self.mu * self.noise_bound ** 2 / self.kappa


def _corner_matrix(ch, v, P, S, Z, kappa, mu, noise: bool):
    """The corner-``v`` quadratic form in ``(X, psi, n)`` (NumPy), to be ``<= 0``.

    ``V(X+) - (1 - T kappa) V(X) - T mu n^2 - 2 T psi^T S ((I - H) psi - G X)`` divided by
    ``T``, with ``Z = S G`` (``S`` diagonal). See the module docstring.
    """
    T, n = ch.T, P.shape[0]
    m = S.shape[0]
    D = (ch.Ms[v] - np.eye(n)) / T
    cols = [D, ch.Bs[v] / T] + ([ch.Es[v][:, None] / T] if noise else [])
    R = np.hstack(cols)
    k = R.shape[1]
    A = np.zeros((k, k))
    PD = P @ D
    A[:n, :n] = PD + PD.T + kappa * P
    A[n:n + m, :n] = (P @ ch.Bs[v] / T).T + Z
    A[n:n + m, n:n + m] = S @ ch.H + ch.H.T @ S - 2.0 * S
    if noise:
        A[n + m, :n] = (P @ ch.Es[v] / T)
        A[n + m, n + m] = -mu
    A = np.tril(A) + np.tril(A, -1).T
    A += T * (R.T @ P @ R)
    return (A + A.T) / 2


def recheck(ch, E: Ellipsoid, S, Z, rooms, X0) -> tuple[float, float]:
    """``(worst, V(X0) / level)``: the worst relative value of every inequality (< 0: all hold).

    Each corner's form (in the coordinates where ``P = I``, a congruence)
    ``lambda_max / ||.||_F``; each inclusion ``value / room^2 - 1``; ``mu nbar^2 / (kappa
    level) - 1``; all shifted by :data:`RECHECK_MARGIN`. Plain NumPy/SciPy.
    """
    P, c, nbar = E.P, E.level, E.noise_bound
    n, m = P.shape[0], S.shape[0]
    Lc = np.linalg.cholesky(P)
    Li = scipy.linalg.solve_triangular(Lc, np.eye(n), lower=True)  # Li P Li^T = I
    k = n + m + (1 if nbar > 0 else 0)
    C = np.eye(k)
    C[:n, :n] = Li.T
    worst = -math.inf
    for v in range(ch.Ms.shape[0]):
        A = C.T @ _corner_matrix(ch, v, P, S, Z, E.kappa, E.mu, nbar > 0) @ C
        worst = max(worst, float(np.linalg.eigvalsh((A + A.T) / 2)[-1]) / np.linalg.norm(A))
    Pi = Li.T @ Li
    d = np.diag(Pi) * c
    for i, r in rooms.items():
        worst = max(worst, d[i] / r ** 2 - 1.0)
    for j in range(m):
        lim = ch.room[j] - abs(ch.kn[j]) * nbar
        if lim <= 0 or S[j, j] <= 0:
            return math.inf, math.inf
        g = ch.K[j] - Z[j] / S[j, j]
        worst = max(worst, c * float(g @ Pi @ g) / lim ** 2 - 1.0)
    if nbar > 0:
        worst = max(worst, E.mu * nbar ** 2 / (E.kappa * c) - 1.0)
    return worst + RECHECK_MARGIN, float(X0 @ P @ X0) / c


def _level_bounds(ch, P, nbar, rooms):
    """``(Lc, Li, Kt, room, lin)``: ``P = Lc Lc^T``, ``Li = Lc^-1``, the rows ``K`` in the
    ``P = I`` coordinates, the largest level inside the rooms and the largest one inside the
    limits' linear regions (inf when none)."""
    n = P.shape[0]
    Lc = np.linalg.cholesky(P)
    Li = scipy.linalg.solve_triangular(Lc, np.eye(n), lower=True)
    Pi = Li.T @ Li
    Kt = ch.K @ Li.T
    room = min([(r / math.sqrt(Pi[i, i])) ** 2 for i, r in rooms.items()] or [math.inf])
    lin = min([(ch.room[j] - abs(ch.kn[j]) * nbar) ** 2 / float(Kt[j] @ Kt[j])
               for j in range(ch.K.shape[0])] or [math.inf])  # the limits inactive
    return Lc, Li, Kt, room, lin


def level_cap(ch, P, *, nbar: float = 0.0, rooms=None) -> float:
    """The largest level :func:`solve_ellipsoid` tries for ``P`` (inf when nothing bounds it):
    ``V(X0) / level_cap`` is a lower bound of the ratio it can return, to the rounding of
    ``exp(log(level))`` (a few ulps; NumPy, no SDP).

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> ch = loop_channels(fl.presets.paper_design(), (3.6, 6.8), None)
    >>> n = ch.Ms.shape[1]
    >>> bool(np.isclose(level_cap(ch, np.eye(n)), 1e6 * min(ch.room ** 2 / (ch.K ** 2).sum(axis=1))))
    True
    """
    P = (np.asarray(P, float) + np.asarray(P, float).T) / 2
    _, _, _, room, lin = _level_bounds(ch, P, float(nbar), dict(rooms or {}))
    return min(room, 1e6 * lin)


def solve_ellipsoid(ch, P, X0, *, kappa: float, nbar: float = 0.0, rooms=None,
                    steps: int = 8):
    """The largest re-checked level of ``V = X^T P X`` (``P`` fixed) with multipliers.

    Tries the largest level the rooms allow (at most 10^6 times the saturation-free one), then
    levels a decade apart down to 10^-4 of the saturation-free one (with noise the certified
    levels are a band), then bisects ``log level`` ``steps`` times above the first that holds;
    each level's multipliers (``S``, ``G``, the noise gain) come from one small SDP, and the
    level kept passes :func:`recheck` (else it is halved, at most 8 times).

    Parameters
    ----------
    ch : LoopChannels
    P : numpy.ndarray
        A quadratic Lyapunov candidate (e.g. the LDI certificate's).
    X0 : array_like
        Loop deviation of the start (reported as ``V(X0) / level``).
    kappa : float
        Decay asked (> 0).
    nbar : float, optional
        Noise peak covered.
    rooms : dict, optional
        ``{coordinate index: half-width}`` the ellipsoid must stay inside.
    steps : int, optional
        Bisection steps.

    Returns
    -------
    (Ellipsoid or None, float, str)
        The ellipsoid, ``V(X0) / level`` (inf when none) and a note.
    """
    from ._sdp_sector import ellipsoid_program

    X0 = np.asarray(X0, float)
    P = (np.asarray(P, float) + np.asarray(P, float).T) / 2
    rooms = dict(rooms or {})
    n, T = P.shape[0], ch.T
    Lc, Li, Kt, room, lin = _level_bounds(ch, P, nbar, rooms)
    # coordinates Xt = Lc^T X: V = |Xt|^2
    Pt = {"n": n, "D": [Lc.T @ ((M - np.eye(n)) / T) @ Li.T for M in ch.Ms],
          "B": [Lc.T @ B / T for B in ch.Bs], "E": [Lc.T @ E[:, None] / T for E in ch.Es]}
    if not math.isfinite(min(room, lin)):
        return None, math.inf, "nothing bounds the ellipsoid (no room, no limits): give a region"
    if any(ch.room[j] - abs(ch.kn[j]) * nbar <= 0 for j in range(ch.K.shape[0])):
        return None, math.inf, f"the noise bound {nbar:g} leaves a limit no room"
    prog, seen = ellipsoid_program(ch, Pt, Kt, kappa, nbar), {}

    def feas(log_level):  # multipliers for V <= exp(log_level), or None (each level once)
        if log_level > math.log(room) + 1e-12:
            return None
        if log_level not in seen:
            seen[log_level] = prog(math.exp(-log_level / 2))
        return seen[log_level]

    hi = math.log(min(room, 1e6 * lin))
    bottom = math.log(min(room, lin)) - math.log(1e4)
    lo = None
    if feas(hi) is not None:
        lo = hi
    else:
        # downward by decades (with noise the feasible levels are a band: not too small
        # either), then bisect between the first feasible level and the decade above it
        level = hi
        while level > bottom:
            level -= math.log(10.0)
            if feas(level) is not None:
                lo, hi = level, level + math.log(10.0)
                break
        if lo is None:
            return None, math.inf, ("no level is certified (from the largest the room allows "
                                    "down to 1e-4 of the largest saturation-free one)")
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            if feas(mid) is not None:
                lo = mid
            else:
                hi = mid
    note = ""
    for back in range(8):  # a solver's "optimal" is not a certificate: step down until it holds
        log_level = lo - back * math.log(2.0)
        level = math.exp(log_level)
        sol = feas(log_level)
        if sol is None:
            continue
        s, Zt, mu = sol
        S = np.diag(s)
        Z = Zt @ Lc.T  # G_t = G Li^T, so Z = S G = Zt Lc^T
        worst, ratio = recheck(ch, Ellipsoid(P, level, float(kappa), mu, float(nbar), 0.0),
                               S, Z, rooms, X0)
        note = f"NumPy re-check worst {worst:.3g} ({'holds' if worst < 0 else 'fails'})"
        if worst < 0:
            break
    if not note or not worst < 0:
        return None, math.inf, note or "the solver gave no multipliers"
    return Ellipsoid(P, level, float(kappa), mu, float(nbar), worst), ratio, note


__all__ = ["Ellipsoid", "LoopChannels", "level_cap", "loop_channels", "recheck",
           "solve_ellipsoid"]
