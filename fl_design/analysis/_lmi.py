"""Vertex LMIs in delta form (CVXPY + Clarabel, SCS as fallback), re-checked in NumPy.

A discrete loop ``X+ = M X`` at ``T = 1 ms`` has eigenvalues within ``1e-6`` of the unit
circle: the naive ``M^T P M - P < 0`` is ``O(T)`` of ``O(1)`` numbers and interior-point
solvers fail on it. With ``M = I + T Delta`` the same condition, divided by ``T``, reads

    Delta^T P + P Delta + T Delta^T P Delta < 0
    <=>  [[-(P Delta + Delta^T P),  sqrt(T) Delta^T P], [sqrt(T) P Delta, P]] > 0

(Schur complement), linear in ``P`` and of order one. The parameter-dependent version (de
Oliveira, Bernussou and Geromel, 1999) has vertex matrices ``P_v`` and one slack ``G``::

    [[P_v, M_v^T G^T], [G M_v, G + G^T - P_v]] > 0

which after the congruence ``[[I, 0], [-I, I]]`` and a ``1/sqrt(T)`` scaling of the first block
becomes, with ``N_v = (P_v - G^T)/sqrt(T) + sqrt(T) G Delta_v``::

    [[-(G Delta_v + Delta_v^T G^T), N_v^T], [N_v, G + G^T - P_v]] > 0

(``P_v = G = P`` gives the common form above). The matrix is affine in ``(P_v, Delta_v)``
jointly, so the vertex conditions hold on the convex hull with ``P(theta)`` interpolated:
every frozen ``M(theta)`` of the polytope is Schur. The common form, with ``P`` independent of
the vertex, also covers ``theta`` varying arbitrarily from sample to sample.

Every solution is re-checked in NumPy: the assembled vertex matrices and the ``P_v`` must have
eigenvalues (``eigvalsh``) above ``RECHECK_TOL`` times their norm. A solver status "optimal" is
not a certificate. Clarabel is called directly (:mod:`._sdp`, one thread, no CVXPY: the
program of :func:`_problem`), on request (``reduced``) the common form as its ``n x n`` Schur
complement ``-(Delta^T P + P Delta + T Delta^T P Delta) >= eta I`` with ``P >= eta I`` (the
cone a quarter of the ``2n`` one's, the solve ~5x faster); the SCS fallback goes through CVXPY
programs compiled once per shape (parameters, DPP) and cached. The re-check is the ``2n`` form.

Examples
--------
>>> import numpy as np
>>> from fl_design.analysis._lmi import vertex_lmi
>>> sol = vertex_lmi([np.array([[-1.0, 1.0], [0.0, -2.0]])], 1e-3, common=True)
>>> sol.certified, sol.solver
(True, 'CLARABEL')
"""

from __future__ import annotations

import contextlib
import functools
import math
import threading
import time
import warnings
from dataclasses import dataclass

import numpy as np

#: Relative margin the NumPy re-check asks of every eigenvalue (``lambda_min > tol ||S||``).
#: It bounds floating-point error with room to spare: ``eigvalsh`` is backward stable (error
#: ``<= p(n) u ||S||``, ``u = 1.1e-16``), and assembling ``S`` from ``P`` and ``Delta`` adds
#: ``<= n u ||S||`` (n <= 40 here): about 1e-14 relative. It was 1e-9, which rejected valid
#: closed-form certificates of wide ``b`` ranges (b in [1, 50]: modal margins 9.9e-10).
RECHECK_TOL = 1e-11


@dataclass(frozen=True)
class LMISolution:
    """Outcome of one vertex LMI: status strings, matrices and the NumPy re-check.

    Parameters
    ----------
    certified : bool
        True only when the NumPy re-check passed.
    solver : str or None
        Solver whose solution was checked (``"CLARABEL"`` or ``"SCS"``).
    solver_status : str
        CVXPY status of that solve (or the error's text).
    P : tuple of numpy.ndarray
        Vertex matrices ``P_v`` (one entry when common), empty when none was found.
    G : numpy.ndarray or None
        The slack (parameter-dependent form).
    margin : float or None
        Smallest ``lambda_min / ||.||`` over the re-checked matrices.
    note : str
        Why not certified, or how (fallbacks).

    Examples
    --------
    >>> LMISolution(False, None, "infeasible", (), None, None, "infeasible").certified
    False
    """

    certified: bool
    solver: str | None
    solver_status: str
    P: tuple
    G: np.ndarray | None
    margin: float | None
    note: str


def _blocks(P, G, D, T: float, kappa: float, xp):
    """Blocks of the delta-form vertex matrix (xp: numpy, or CVXPY expressions)."""
    sT = math.sqrt(T)
    GD = G @ D
    A11 = -(GD + GD.T) - 2.0 * kappa * P
    A21 = (P - G.T) / sT + sT * GD
    A22 = G + G.T - P
    return xp([[A11, A21.T], [A21, A22]])


@functools.lru_cache(maxsize=64)
def _problem(n: int, nv: int, T: float, common: bool):
    """Maximize the margin ``eta``: ``S_v >= eta I``, ``eta I <= P_v <= I`` (homogeneous)."""
    import cvxpy as cp

    D = [cp.Parameter((n, n)) for _ in range(nv)]
    kappa = cp.Parameter(nonneg=True)
    eta = cp.Variable()
    if common:
        P = cp.Variable((n, n), symmetric=True)
        Ps, G = [P] * nv, P
    else:
        Ps = [cp.Variable((n, n), symmetric=True) for _ in range(nv)]
        G = cp.Variable((n, n))
    eye, eye2 = np.eye(n), np.eye(2 * n)
    cons = [eta <= 1.0]
    for Pv, Dv in zip(Ps, D):
        S = _blocks(Pv, G, Dv, T, kappa, cp.bmat)
        cons.append((S + S.T) / 2 >> eta * eye2)
    for Pv in Ps[: 1 if common else nv]:
        cons += [Pv >> eta * eye, Pv << eye]
    return cp.Problem(cp.Maximize(eta), cons), D, kappa, Ps, G, eta


def _direct_blocks(deltas, T: float, common: bool, kappa: float, reduced: bool = False):
    """The blocks of :func:`._sdp.max_margin` for :func:`_problem`'s LMI, and the map from
    its variables to ``(P_v..., G)``.

    Common ``P``: the vertex condition in its ``n x n`` form
    ``-(Delta^T P + P Delta + T Delta^T P Delta) - 2 kappa P >= eta I`` (the Schur complement
    of the ``2n`` one for ``P > 0``: a quarter of the cone, a sixty-fourth of its KKT block);
    parameter-dependent: the ``2n`` slack form of the module docstring.
    """
    from ._sdp import sym_basis

    n, nv = deltas[0].shape[0], len(deltas)
    Bs = sym_basis(n)
    m = Bs.shape[0]
    eye = np.eye(n)
    if common and reduced:
        blocks = []
        for D in deltas:
            BD = Bs @ D
            F = -(BD + np.swapaxes(BD, -1, -2) + T * (D.T @ BD)) - 2.0 * kappa * Bs
            blocks.append((np.zeros((n, n)), F, True))
        blocks += [(np.zeros((n, n)), Bs, True), (eye, -Bs, False)]

        def unpack(x):
            P = np.tensordot(x, Bs, axes=1)
            return (P,), P
        return blocks, m, unpack
    sT = math.sqrt(T)
    if common:  # the 2n form with G = P: P's basis enters every block
        nP, Eg, nvar = 1, Bs, m
    else:
        Eg = np.zeros((n * n, n, n))
        Eg[np.arange(n * n), np.arange(n * n) // n, np.arange(n * n) % n] = 1.0
        nP, nvar = nv, nv * m + n * n
    g0 = 0 if common else nv * m  # where G's coefficients start
    blocks = []
    for v, D in enumerate(deltas):
        F = np.zeros((nvar, 2 * n, 2 * n))
        if not common:
            sl = slice(v * m, (v + 1) * m)
            F[sl, n:, :n] = Bs / sT
            F[sl, :n, n:] = Bs / sT
            F[sl, n:, n:] = -Bs
        ED = Eg @ D
        EDt = np.swapaxes(ED, -1, -2)
        Et = np.swapaxes(Eg, -1, -2)
        A21 = -Et / sT + sT * ED
        F[g0:, :n, :n] += -(ED + EDt) - (2.0 * kappa * Eg if common else 0.0)
        F[g0:, n:, :n] += A21 + (Eg / sT if common else 0.0)
        F[g0:, :n, n:] += np.swapaxes(A21, -1, -2) + (Eg / sT if common else 0.0)
        F[g0:, n:, n:] += Eg + Et - (Eg if common else 0.0)
        blocks.append((np.zeros((2 * n, 2 * n)), F, True))
    for v in range(nP):
        Fp = np.zeros((nvar, n, n))
        Fp[v * m:(v + 1) * m] = Bs
        blocks += [(np.zeros((n, n)), Fp, True), (eye, -Fp, False)]

    def unpack(x):
        Ps = tuple(np.tensordot(x[v * m:(v + 1) * m], Bs, axes=1) for v in range(nP))
        return Ps, (Ps[0] if common else x[nv * m:].reshape(n, n))
    return blocks, nvar, unpack


def _solve_direct(deltas, T: float, common: bool, kappa: float, reduced: bool = False):
    """:func:`_problem`'s LMI through :func:`._sdp.max_margin`: ``(status, P tuple, G, eta)``
    (None where Clarabel gave no solution); counted by :func:`solve_count`."""
    from ._sdp import max_margin

    blocks, nvar, unpack = _direct_blocks(deltas, T, common, kappa, reduced)
    r = counted(max_margin, blocks, nvar)
    if r.x is None:
        return r.status, None, None, r.eta
    P, G = unpack(r.x)
    return r.status, P, G, r.eta


def recheck(P, G, deltas, T: float, kappa: float = 0.0, delta_error: float = 0.0) -> float:
    """Smallest ``lambda_min / ||.||_2`` of the ``P_v`` and the assembled vertex matrices.

    Plain NumPy (``eigvalsh`` of the symmetric part); the certificate holds when the value
    exceeds :data:`RECHECK_TOL`. ``delta_error``: a bound on ``||Delta_v - exact||_2`` of
    deltas computed by a similarity (:func:`recheck_stack`).

    Examples
    --------
    >>> import numpy as np
    >>> recheck([np.eye(1)], np.eye(1), [np.array([[-1.0]])], 1e-3) > 0
    True
    """
    Ps = list(P) if len(P) == len(deltas) else [P[0]] * len(deltas)
    k = len(deltas)
    return float(np.min(recheck_stack(np.stack(Ps), np.broadcast_to(G, (k,) + np.shape(G)),
                                      np.stack(deltas), T, kappa, delta_error)))


def recheck_stack(P, G, D, T: float, kappa: float = 0.0,
                  delta_error: float = 0.0) -> np.ndarray:
    """:func:`recheck` of many triples ``(P_i, G_i, Delta_i)`` at once (stacked ``eigvalsh``).

    Returns the margin of each triple: the smaller ``lambda_min / ||.||_2`` of ``P_i`` and of
    its assembled vertex matrix. With ``delta_error`` (a bound on the 2-norm of the error of
    each ``Delta_i``, e.g. of a similarity computed in floating point) the vertex matrix's
    ``lambda_min`` is first lowered by the most that error can move it,
    ``||G_i||_2 (2 + sqrt(T)) delta_error`` (the matrix is affine in ``Delta`` with
    coefficient blocks ``G`` and ``sqrt(T) G``): the margin then holds for the exact deltas.

    Examples
    --------
    >>> import numpy as np
    >>> I = np.eye(1)[None]
    >>> recheck_stack(I, I, np.array([[[-1.0]], [[1.0]]]), 1e-3).round(3).tolist()
    [0.499, -1.0]
    """
    P, G, D = (np.asarray(a, dtype=float) for a in (P, G, D))
    P, G = np.broadcast_to(P, D.shape), np.broadcast_to(G, D.shape)
    n, sT = D.shape[-1], math.sqrt(T)
    GD = G @ D
    S = np.empty(D.shape[:-2] + (2 * n, 2 * n))
    S[..., :n, :n] = -(GD + np.swapaxes(GD, -1, -2)) - 2.0 * kappa * P
    A21 = (P - np.swapaxes(G, -1, -2)) / sT + sT * GD
    S[..., n:, :n], S[..., :n, n:] = A21, np.swapaxes(A21, -1, -2)
    S[..., n:, n:] = G + np.swapaxes(G, -1, -2) - P
    out = np.full(D.shape[:-2], np.inf)
    shift = 0.0
    if delta_error:
        shift = np.linalg.norm(G, 2, axis=(-2, -1)) * (2.0 + sT) * float(delta_error)
    for M, dl in (((P + np.swapaxes(P, -1, -2)) / 2, 0.0), ((S + np.swapaxes(S, -1, -2)) / 2,
                                                            shift)):
        lam = np.linalg.eigvalsh(M)
        rel = (lam[..., 0] - dl) / np.maximum(np.abs(lam[..., 0]), np.abs(lam[..., -1]))
        out = np.minimum(out, rel)
    return out


_SOLVES = threading.local()


def solve_count() -> int:
    """Conic programs (LMIs, SOS) this thread has solved through :func:`_solve` so far.

    A counter for progress lines (the difference between two readings); nothing reads it
    to decide anything.

    Examples
    --------
    >>> from fl_design.analysis._lmi import solve_count
    >>> solve_count() >= 0
    True
    """
    return getattr(_SOLVES, "n", 0)


@contextlib.contextmanager
def solve_progress(callback, every: float = 2.0):
    """Call ``callback()`` after a conic program is solved in this thread, at most once per
    ``every`` seconds, inside the ``with`` block: a caller's progress line during a long
    certificate (read with :func:`solve_count`). Nothing it does decides anything.

    Examples
    --------
    >>> import cvxpy as cp
    >>> from fl_design.analysis._lmi import solve_progress, solve_quietly
    >>> x, seen = cp.Variable(), []
    >>> with solve_progress(lambda: seen.append(1), every=0.0):
    ...     _ = solve_quietly(cp.Problem(cp.Minimize(x), [x >= 1]))
    >>> seen
    [1]
    """
    every = float(every)
    previous = getattr(_SOLVES, "listener", None)
    _SOLVES.listener = [callback, every, time.perf_counter()]
    try:
        yield
    finally:
        _SOLVES.listener = previous


def counted(solve, *args):
    """``solve(*args)``, counted as one conic program by :func:`solve_count` (its listener
    told): for a program handed to a solver directly (:mod:`._sdp`)."""
    _SOLVES.n = solve_count() + 1
    try:
        return solve(*args)
    finally:
        listener = getattr(_SOLVES, "listener", None)
        if listener is not None and time.perf_counter() - listener[2] >= listener[1]:
            listener[2] = time.perf_counter()
            listener[0]()


def _solve(problem, solver: str) -> str:
    """Solve ``problem`` with ``solver``, its warnings silenced; the CVXPY status."""
    return counted(_solve_once, problem, solver)


def _solve_once(problem, solver: str) -> str:
    import cvxpy as cp

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if solver == "SCS":
            problem.solve(solver=cp.SCS, eps=1e-8, max_iters=2500)
        else:
            problem.solve(solver=cp.CLARABEL)
    return str(problem.status)


def solve_quietly(problem, solver: str = "CLARABEL") -> Exception | None:
    """Solve ``problem`` (warnings silenced); the exception a solver raised, else None.

    A solver failure is a value for a certificate (no certificate, with the reason), never an
    error: every LMI and SOS program of the package is solved through here or :func:`_solve`.

    Examples
    --------
    >>> import cvxpy as cp
    >>> x = cp.Variable()
    >>> p = cp.Problem(cp.Minimize(x), [x >= 1])
    >>> solve_quietly(p) is None, round(float(x.value), 6)
    (True, 1.0)
    """
    try:
        _solve(problem, solver)
    except Exception as err:  # noqa: BLE001 - a solver failure is a value, not an error
        return err
    return None


def vertex_lmi(deltas, T: float, *, common: bool = False, kappa: float = 0.0,
               fallback: bool = True, delta_error: float = 0.0,
               reduced: bool = False) -> LMISolution:
    """Solve the delta-form vertex LMI for the matrices ``Delta_v``; never raises on failure.

    Parameters
    ----------
    deltas : sequence of numpy.ndarray
        Vertex matrices ``Delta_v = (M_v - I)/T`` (already balanced by the caller).
    T : float
        Sampling time.
    common : bool, optional
        One ``P`` for all vertices (covers time-varying parameters) instead of ``P_v`` + ``G``.
    kappa : float, optional
        Decay rate asked (common form only): ``M^T P M <= (1 - 2 kappa T) P``.
    fallback : bool, optional
        Try SCS when Clarabel fails (default True; about 1 s per solve, rarely certifies what
        Clarabel could not: the fast curve turns it off).
    delta_error : float, optional
        A bound on ``||Delta_v - exact||_2`` when the deltas come from a similarity computed
        in floating point (:mod:`._slow_fast`): the re-check holds for the exact ones.
    reduced : bool, optional
        Common form only: solve the ``n x n`` Schur complement (about 5x faster; the same
        feasible set, another optimal ``P``: the curve uses it, the certificates whose ``P``
        is used further, e.g. for a contraction or an invariant set, keep the ``2n`` form).

    Returns
    -------
    LMISolution

    Examples
    --------
    >>> import numpy as np
    >>> vertex_lmi([np.array([[1.0]])], 1e-3).certified  # unstable: no certificate
    False
    """
    deltas = [np.asarray(D, dtype=float) for D in deltas]
    n = deltas[0].shape[0]
    kap = float(kappa) if common else 0.0
    notes, last = [], "not solved"
    for solver in ("CLARABEL", "SCS") if fallback else ("CLARABEL",):
        if solver == "CLARABEL":  # directly (:mod:`._sdp`): no CVXPY on this path
            last, P, Gv, eta_value = _solve_direct(deltas, float(T), bool(common), kap,
                                                   bool(reduced))
            if last.startswith("solver_error"):
                notes.append(f"{solver} failed ({last})")
                continue
        else:
            problem, D, kpar, Ps, G, eta = _problem(n, len(deltas), float(T), bool(common))
            for par, Dv in zip(D, deltas):
                par.value = Dv
            kpar.value = kap
            err = solve_quietly(problem, solver)
            if err is not None:
                last = f"{type(err).__name__}: {err}".splitlines()[0][:120]
                notes.append(f"{solver} failed ({last})")
                continue
            last, eta_value = str(problem.status), eta.value
            P = (None if Ps[0].value is None else
                 tuple(np.array(Pv.value) for Pv in (Ps[:1] if common else Ps)))
            Gv = None if P is None else (P[0] if common else np.array(G.value))
        if last in ("infeasible", "infeasible_inaccurate") or (
                eta_value is not None and eta_value <= 0.0):
            return LMISolution(False, solver, last, (), None, None,
                               "; ".join(notes + [(f"{solver}: no strictly feasible point "
                                                  f"(status {last})")]))
        if P is None or eta_value is None:
            notes.append(f"{solver} returned no solution ({last})")
            continue
        margin = recheck(P, Gv, deltas, T, kap, delta_error)
        if margin > RECHECK_TOL:
            note = "; ".join(notes + [f"{solver}: {last}, re-checked in NumPy"])
            return LMISolution(True, solver, last, P, Gv, margin, note)
        return LMISolution(False, solver, last, (), None, margin, "; ".join(
            notes + [(f"{solver} solution ({last}) failed the NumPy re-check "
                     f"(margin {margin:.3g} <= {RECHECK_TOL:g})")]))
    return LMISolution(False, None, last, (), None, None, "; ".join(notes))


def balance_scaling(deltas) -> np.ndarray:
    """Scaling ``s`` (powers of 2) of :func:`balance`: ``Delta_v -> diag(1/s) Delta_v diag(s)``.

    A ``P_b`` certified for the balanced matrices is ``diag(1/s) P_b diag(1/s)`` in the
    original coordinates (a congruence: the same certificate).

    Examples
    --------
    >>> import numpy as np
    >>> balance_scaling([np.array([[0.0, 1e6], [1e-6, 0.0]])]).tolist()
    [1048576.0, 1.0]
    """
    import scipy.linalg

    total = sum(np.abs(D) for D in deltas)
    _, (s, _) = scipy.linalg.matrix_balance(total, permute=False, separate=True)
    return s


def balance(deltas) -> list[np.ndarray]:
    """Diagonal similarity scaling (powers of 2, exact) of the ``Delta_v``, all alike.

    Examples
    --------
    >>> import numpy as np
    >>> B = balance([np.array([[0.0, 1e6], [1e-6, 0.0]])])[0]
    >>> bool(B.max() < 2.0)
    True
    """
    s = balance_scaling(deltas)
    return [D * s[None, :] / s[:, None] for D in deltas]


__all__ = ["RECHECK_TOL", "LMISolution", "balance", "balance_scaling", "recheck", "recheck_stack",
           "solve_count", "vertex_lmi"]
