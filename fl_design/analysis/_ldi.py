"""Linear-differential-inclusion certificate with bounds on ``b`` and ``d sigma/dx``.

**Setting.** A plant without internal dynamics (``rho = n``) in its normal-form coordinates
``x = (y, y', ..., y^(rho-1))``, ``x_rho' = sigma(x, u) = a(x) + b(x) u``, held at an
equilibrium ``(x_eq, u_eq)`` inside a convex box ``R`` of ``x``. In deviation coordinates, by
the mean-value theorem along the segment from ``x_eq`` to ``x`` (inside ``R``)::

    sigma(x, u) - sigma(x_eq, u_eq) = abar(t)^T (x - x_eq) + b(x(t)) (u - u_eq)

with ``abar_i(t)`` in ``[min_R, max_R] of d sigma(., u_eq)/dx_i`` (``a_jacobian_bounds``) and
``b(x) in b_bounds``: the continuous plant is *exactly* a member of the LDI
``x' = A(theta(t)) x + e_rho b(t) u``, ``theta(t)`` anywhere in the box, varying in time.

**Sample maps.** Over one sample (``u`` held) the augmented state ``z = (x, u)`` obeys
``z' = X(t) z`` with ``X(t) = [[chain(abar(t)), e_rho bbar(t)], [0, 0]]``, every entry inside
the box spanned by the vertex matrices ``X_v`` (``X_lo <= X(t) <= X_hi`` entrywise). Its
transition ``Psi`` is enclosed in one of two ways:

* **Interval ZOH model** (exact for stiff entries, no remainder), when ``X_lo`` is Metzler
  (off-diagonal entries >= 0: ``d sigma/d xi_i >= 0`` for ``i < rho`` and ``b > 0``; the
  diagonal ``d sigma/d xi_rho``, e.g. a friction slope of any stiffness, is free). Then
  ``expm(T X_lo) <= Psi <= expm(T X_hi)`` entrywise, for every measurable ``X(t)`` in the box.
  *Argument:* ``X(t) >= X_lo`` off the diagonal, so ``X(t)`` is Metzler and ``Psi(t) >= 0``
  (a Metzler system keeps the non-negative orthant). ``E = expm(t X_hi) - Psi(t)`` obeys
  ``E' = X_hi E + (X_hi - X(t)) Psi(t)``, ``E(0) = 0``: the forcing is ``>= 0`` and ``X_hi``
  is Metzler, so ``E(t) = int expm((t - s) X_hi) (X_hi - X(s)) Psi(s) ds >= 0``; likewise
  ``Psi(t) - expm(t X_lo) >= 0``. Both ends are moved outward by ``8 ulp`` for the rounding of
  ``expm``. The loop matrix ``M(Psi)`` is affine in ``Psi`` and ``||M||_P`` convex in it, so the
  corners of the box (``2^k``, ``k`` the entries with ``lo < hi``, at most
  :data:`MAX_BOX_CORNERS`) are the vertices to check; no remainder.
* **First-order model** otherwise (e.g. the pendulum's ``-g cos theta < 0``): the Peano-Baker
  series ``Psi = expm(T X_c) + T (X(thetabar) - X_c) + R`` (``X_c`` the box's center,
  ``thetabar`` the time average of ``theta(t)``, inside the box; ``|R| <= Rbar`` entrywise,
  :func:`._sample_model._remainder_bound`): the vertices are the affine model's, plus the remainder.

**Certificate.** One common ``P`` satisfies the delta-form vertex LMI for the loops ``M_v`` of
the vertices with a decay rate (coordinates: balanced, else a real modal basis), and NumPy
checks ``max_v ||M_v||_P (+ || |L^T W^-1 E| Rbar |J W L^-T| ||_2`` for the first-order model)
``< 1`` (``P = L L^T`` in the LMI's coordinates ``X = W X_b``, ``J`` the map of the loop state
to ``(x, u_k)``): every sample map of the LDI contracts ``V``.

**What it guarantees for the nonlinear plant.** With ``V(X) = X^T P X`` on the sampled loop
state (plant deviation, observer, ``u``, ``z``), ``V(X_(k+1)) <= q^2 V(X_k)`` with ``q < 1``
(``q`` stored in the reason) for every sample at which the plant state stays in ``R`` over the
sample and the clamps and input saturation are inactive: any sublevel set of ``V`` on which
those hold is invariant and the sampled loop converges to the equilibrium exponentially. The
bounds are the caller's: by interval arithmetic from
:func:`fl_design.analysis._plant_bounds.plant_bounds` (``a_jacobian_bounds="plant"``, an
enclosure) or given (e.g. :meth:`fl_design.Plant.jacobian_bounds`, dense sampling: not an
enclosure). Nothing is claimed outside ``R`` or with saturation active;
:mod:`._region` searches the region and reports the covered initial states.

Examples
--------
>>> import fl_design as fl
>>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.01, T=1e-3),
...               controller=fl.DynamicController((2, 4), 1e-2))
>>> c = fl.certify_eps(d, (1.0, 1.0), a_jacobian_bounds=[(-9.81, -8.6), (-0.5, -0.5)],
...                    search=False)
>>> c.point.kind, c.point.covers_time_varying_b
('ldi', True)
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ._cert_results import PointCertificate, _Result
from ._lmi import RECHECK_TOL, vertex_lmi
from ._sample_model import (  # noqa: F401 - _box_corners, _metzler_box, _remainder_bound: API of
    MAX_BOX_CORNERS,  # this module before they moved (._sector, the tests)
    _box_corners,
    _metzler_box,
    _remainder_bound,
    _sample_maps,
)
from ._surrogate import chain_matrices, delta, schur_margins

#: Fraction of the slowest vertex decay rate asked of the common ``P``.
DECAY_FRACTION = 0.8
#: Corner pairs of the second-order model added to the LMI when its first P fails them.
PAIRS_ADDED = 2


def _vertices(L):
    corners = np.unique(L._corners(), axis=0)  # a degenerate range gives one corner
    return [(a, b) for a in corners for b in sorted({L.b_lo, L.b_hi})]


def _vertex_words(a_row, b) -> str:
    return f"d sigma/d xi = ({', '.join(f'{v:.6g}' for v in a_row)}), b = {b:.6g}"


def _why_not_schur(L, verts, Xs, Ms, margins, u_row, eps, gamma, model) -> str:
    """Which vertex of the first-order model fails, by how much, and its exact ZOH."""
    v = int(np.argmax(margins))
    rad = float(np.max(np.abs(np.linalg.eigvals(Ms[v]))))
    rho = L.loop.rho
    E = scipy.linalg.expm(L.T * Xs[v])
    M0, M1 = L.loop.assemble(E[:rho, :rho], E[:rho, rho], u_row, eps, gamma)
    zoh = float(np.max(np.abs(np.linalg.eigvals(M0 + M1))))
    half = 0.5 * (np.max(Xs, axis=0) - np.min(Xs, axis=0))
    stiff = L.T * float(np.max(half[rho - 1, :rho]))
    tail = (f"its exact ZOH is Schur (spectral radius {zoh:.9f}): what fails is the model "
            f"around the box centre X_c ({model}), whose terms in the deviation from X_c are "
            f"too large (T x the half-width of the d sigma/d xi box = {stiff:.3g}); a ZOH "
            "vertex model with a bounded remainder would be needed" if zoh < 1.0 else
            f"its exact ZOH is not Schur either (spectral radius {zoh:.9f}): with this design the "
            "plant frozen at that vertex is unstable")
    return (f"LDI: the vertex model is not Schur at vertex {v + 1} of {len(verts)} "
            f"({_vertex_words(*verts[v])}): spectral radius {rad:.9f}, Schur margin "
            f"{float(margins[v]):.3g} >= 0; {tail}")


def _coordinates(D):
    """Similarity transforms to try for the common-P LMI: balancing, then a real modal basis."""
    _, (s, _) = scipy.linalg.matrix_balance(sum(np.abs(x) for x in D), permute=False,
                                            separate=True)
    yield np.diag(s)
    from ._analytic import real_modal_basis

    W = real_modal_basis(sum(D) / len(D))
    if np.linalg.cond(W) < 1e8:
        yield W


def _vertex_loops(L, eps: float, gamma: float, second_order: bool = False):
    """``(verts, Xs, maps, Rbar, model, Ms, D, margins, u_row, Dchk)`` of the LDI at one eps
    (``Dchk``: the delta matrices the re-check covers, ``D`` itself or more).

    ``second_order`` False (default): the first-order model where the box is not Metzler, the
    model the step certificate's sample-map box (:func:`._sector._psi_box`) re-checks with, so
    its candidates (:mod:`._start_lmi`) are posed on the same maps; :func:`ldi_point` asks for
    the second-order model of :mod:`._sample_model` (its remainder in the P-norm: 4x smaller
    on the pendulum, 300-3000x on the benchmark slope box at eps = 1-4 ms).
    """
    T, rho, loop = L.T, L.loop.rho, L.loop
    u_row = loop.input_row(eps, gamma)
    verts = _vertices(L)
    Xs = []
    for a_row, b in verts:
        X = chain_matrices(rho, a_row)
        X[:, rho] *= b
        Xs.append(X)
    maps, Rbar, model, check = _sample_maps(L, np.stack(Xs), second_order)

    def deltas(ps):
        out = []
        for Psi in ps:
            M0, M1 = loop.assemble(Psi[:rho, :rho], Psi[:rho, rho], u_row, eps, gamma)
            out.append(M0 + M1)
        return out, [delta(M, T) for M in out]

    Ms, D = deltas(maps)
    Dchk = D if check is None else deltas(check)[1]
    return verts, Xs, maps, Rbar, model, Ms, D, schur_margins(np.stack(D), T), u_row, Dchk


def vertex_switching(Ms, pairs: int):
    """``(i, j, Refutation)``: a periodic switching between two vertex loops ``Ms[i]``,
    ``Ms[j]`` that grows (the first of at most ``pairs`` pairs, in order), else None.

    A common ``P`` with ``||M_v||_P < 1`` at every vertex contracts every product of vertex
    loops, so a growing period proves that no common quadratic ``P`` exists (the LMI would be
    infeasible): a refutation of the certificate, not of the plant.
    """
    from ._refute import switching_refutation

    for n, (i, j) in enumerate(itertools.combinations(range(len(Ms)), 2)):
        if n >= pairs:
            break
        r = switching_refutation(lambda t, a=Ms[i], b=Ms[j]: a if t < 0.5 else b, 0.0, 1.0,
                                 None)
        if r.refuted:
            return i, j, r
    return None


def ldi_point(L, eps: float, gamma: float, *, refute_pairs: int = 0) -> PointCertificate:
    """Common-P certificate of the sampled LDI at one eps (see the module docstring).

    ``refute_pairs > 0``: before the LMIs, periodic switchings between that many pairs of
    vertex loops are tried (:func:`vertex_switching`, tens of milliseconds); one that grows
    answers "no common P" without an LMI (the answer the LMIs would give, and why).
    """
    T = L.T
    verts, Xs, maps, Rbar, model, Ms, D, margins, u_row, Dchk = _vertex_loops(
        L, eps, gamma, second_order=True)
    if np.max(margins) >= 0.0:
        if Rbar is not None:
            return PointCertificate(float(eps), False, None, 0, False, None, "not solved", None,
                                    _why_not_schur(L, verts, Xs, Ms, margins, u_row, eps, gamma, model))
        v = int(np.argmax(margins))
        rad = float(np.max(np.abs(np.linalg.eigvals(Ms[v]))))
        return PointCertificate(
            float(eps), False, None, 0, False, None, "not solved", None,
            f"LDI ({model}): the loop of corner {v + 1} of {len(maps)} of the enclosure is not "
            f"Schur (spectral radius {rad:.9f}): no common P; a smaller region narrows the box")
    found = vertex_switching(Ms, refute_pairs) if refute_pairs > 0 and len(Ms) > 1 else None
    if found is not None:
        i, j, r = found
        return PointCertificate(
            float(eps), False, None, 0, False, None, "not solved", None,
            f"LDI ({model}): every vertex loop is Schur, but switching between vertex loops "
            f"{i + 1} and {j + 1} of {len(maps)} grows (spectral radius {r.radius:.9f} over a "
            f"{r.period}-sample period): no common quadratic P exists, no LMI solved; a "
            "smaller region narrows the Jacobian box")
    kappa = DECAY_FRACTION * float(-np.max(margins)) / 2.0
    got = _solve(L, D, Dchk, Rbar, u_row, T, kappa)
    if not got[0].certified:
        sol, v = got[0], int(np.argmax(margins))
        return PointCertificate(
            float(eps), False, None, 0, False, sol.solver, sol.solver_status, sol.margin,
            f"LDI ({model}): every vertex loop is Schur (the least stable, {v + 1} of "
            f"{len(maps)}, has spectral radius {np.sqrt(1.0 + T * float(margins[v])):.9f}), but "
            "no common quadratic P covers them "
            f"all varying in time ({got[1]}); a smaller region narrows the Jacobian box")
    sol, _, Wi, q, nu, dP = got
    ok = q < 1.0 - RECHECK_TOL
    P = Wi.T @ sol.P[0] @ Wi  # the loop's own coordinates (X = W X_b)
    rem = "" if Rbar is None else f" + remainder {dP:.3g}"
    over = f"{len(Dchk)} sample maps" + ("" if len(Dchk) == len(D) else
                                         f" (the LMI posed on {len(D)})")
    why = ("" if ok else f": the remainder bound exceeds the contraction 1 - ||M||_P = "
           f"{1.0 - nu:.3g} by {q - 1.0:.3g}" if nu < 1.0 else
           ": P does not contract every sample map (no common quadratic P found for them all)")
    reason = (f"LDI ({model}), common P over {over}: ||M||_P <= {nu:.12f}"
              f"{rem} = {q:.12f} {'<' if ok else '>='} 1 (NumPy){why}")
    return PointCertificate(float(eps), ok, "ldi" if ok else None, 1 if ok else 0, ok,
                            sol.solver, sol.solver_status, sol.margin, reason,
                            ((L.b_lo, L.b_hi),) if ok else (), ((P, P),) if ok else ())


@dataclass(frozen=True, repr=False)
class CoveredSet(_Result):
    """The initial loop states a nonlinear (LDI) certificate covers: ``V(X) <= level``.

    ``X`` is the deviation of the sampled loop state (plant, estimator, ``u``, ``z``) from
    the equilibrium, ``V(X) = X^T P X`` the certificate's function. The set is the largest
    sublevel set of ``V`` inside the region (and the input range, when the design saturates):
    ``level = min_i r_i^2 / (P^-1)_ii`` over the constrained coordinates, ``r_i`` their room.
    On it every sample contracts ``V`` (the LDI holds), so it is invariant and every
    trajectory starting in it converges. The room is checked at the sampling instants; between
    two samples the state moves by at most ``T max|x'|`` (1 ms at the pendulum's 10 rad/s:
    0.01 rad), which the region's own margin must absorb. Estimate clamps are not accounted
    for.

    Parameters
    ----------
    level : float
        The sublevel ``c`` (0 when the equilibrium is on the region's boundary).
    P : numpy.ndarray
        ``V``'s matrix in the loop coordinates ``names``.
    names : tuple of str
        The loop coordinates.
    half_widths : tuple of float
        The set's extent along each coordinate, ``sqrt(c (P^-1)_jj)``.
    x_eq : tuple of float
        The plant's equilibrium in normal-form coordinates.
    binding : str
        The coordinate whose room sets the level.

    Examples
    --------
    >>> import numpy as np
    >>> c = covered_set(np.diag([1.0, 4.0]), ("x_1", "x_2"), (0.0, 0.0), {0: 0.5, 1: 1.0})
    >>> round(c.level, 6), [round(w, 6) for w in c.half_widths], c.binding
    (0.25, [0.5, 0.25], 'x_1')
    """

    level: float
    P: np.ndarray
    names: tuple
    half_widths: tuple
    x_eq: tuple
    binding: str

    def contains(self, X) -> bool:
        """``V(X) <= level`` for a loop deviation ``X`` (coordinates ``names``).

        Examples
        --------
        >>> import numpy as np
        >>> covered_set(np.eye(1), ("x_1",), (0.0,), {0: 1.0}).contains([0.5])
        True
        """
        X = np.asarray(X, dtype=float)
        return bool(X @ self.P @ X <= self.level)

    def to_dict(self) -> dict:
        out = super().to_dict()
        out["P"] = np.asarray(self.P).tolist()
        return out

    def _repr_lines(self):
        return [f"V(X) <= {self.level:.6g} (bound by {self.binding}); extent "
                + ", ".join(f"{n} +-{w:.4g}" for n, w in zip(self.names, self.half_widths))]


def covered_set(P, names, x_eq, room: dict) -> CoveredSet:
    """The largest sublevel set of ``X^T P X`` with ``|X_i| <= room[i]`` (see CoveredSet).

    Parameters
    ----------
    P : array_like
        Positive definite ``V`` matrix in the loop coordinates.
    names : sequence of str
        The loop coordinates.
    x_eq : sequence of float
        The plant's equilibrium (normal-form coordinates), recorded.
    room : dict
        ``{index: r}``: the constrained coordinates and their room ``|X_i| <= r``.

    Returns
    -------
    CoveredSet

    Examples
    --------
    >>> import numpy as np
    >>> covered_set(np.eye(2), ("a", "b"), (0.0,), {1: 2.0}).level
    4.0
    """
    P = np.asarray(P, dtype=float)
    Pi = np.linalg.inv((P + P.T) / 2)
    levels = {i: r * r / Pi[i, i] for i, r in room.items()}
    i = min(levels, key=levels.get)
    level = max(0.0, float(levels[i]))
    return CoveredSet(level, P, tuple(names), tuple(float(math.sqrt(level * Pi[j, j]))
                                                    for j in range(P.shape[0])),
                      tuple(float(v) for v in x_eq), str(names[i]))


def _screen(D, T, scs):
    """The common-P LMI without decay in its ``n x n`` Schur-complement form (the same feasible
    set as the ``2n`` one for ``P > 0``, about 5x cheaper; :func:`._lmi.vertex_lmi`
    ``reduced``): its solution when it has no strictly feasible point (then neither the ``2n``
    form nor a decay rate has one, in any coordinates: a similarity maps one ``P`` to another),
    else None (the ``2n`` form is solved for the ``P`` the contraction uses). Only a clean
    answer refutes: a solver failure or a solution that fails its re-check does not."""
    W = next(_coordinates(D))
    Wi = np.linalg.inv(W)
    sol = vertex_lmi([Wi @ x @ W for x in D], T, common=True, kappa=0.0, fallback=scs,
                     reduced=True)
    infeasible = sol.solver_status in ("infeasible", "infeasible_inaccurate") or (
        sol.solver_status == "optimal" and sol.margin is None)
    return sol if not sol.certified and infeasible else None


def _solve(L, D, Dchk, Rbar, u_row, T, kappa):
    """``(sol, W, W^-1, q, nu, dP)`` of the common-P LMI (``sol`` not certified: ``(sol,
    notes)``): balanced coordinates with the decay rate ``kappa``, then without (only without
    once that worked last on ``L``), then (unless the solver found it cleanly infeasible, which
    no similarity changes) a real modal basis without; the re-check covers ``Dchk``
    (the second-order model's corner pairs: when they fail, the LMI again with the worst
    :data:`PAIRS_ADDED` of them)."""
    loop, notes = L.loop, []
    scs = getattr(L, "scs", True)  # SCS after a Clarabel failure unless the caller (the curve) says not
    # the n x n form (same feasible set, another P: the contraction may differ) for loops of at
    # least L.ldi_reduced_from states (the curve: 8, rho >= 3, where the 2n form costs ~0.4 s)
    red = D[0].shape[0] >= getattr(L, "ldi_reduced_from", np.inf)
    # no decay first when the loop said so, or in the n x n form (there the first solve is the
    # screen's own problem: a failure without decay ends the point, decay is harder)
    kappas = (0.0, kappa) if red or getattr(L, "ldi_no_decay", False) else (kappa, 0.0)
    if getattr(L, "ldi_screen", False) and not red:  # the curve: refuted by the cheap form first
        screen = _screen(D, T, scs)
        if screen is not None:
            return screen, screen.note
    for n_w, W in enumerate(_coordinates(D)):
        Wi = np.linalg.inv(W)
        Db = [Wi @ x @ W for x in D]
        for k in kappas if n_w == 0 else (0.0,):
            sol = vertex_lmi(Db, T, common=True, kappa=k, fallback=scs, reduced=red)
            if sol.certified or k == 0.0:
                break  # (no decay infeasible: a decay rate is too)
        if sol.certified:
            break
        notes.append(sol.note)
        if sol.margin is None and sol.solver_status in ("infeasible", "optimal"):
            break  # cleanly infeasible: a similarity (the modal basis) cannot change that
    if not sol.certified:
        return sol, "; ".join(notes)
    try:
        L.ldi_no_decay = k == 0.0
    except AttributeError:  # pragma: no cover - a loop object without attributes
        pass
    Dc = [Wi @ x @ W for x in Dchk]
    q, nu, dP = _contraction(sol.P[0], Dc, W, Rbar, u_row, loop, T)
    if not q < 1.0 - RECHECK_TOL and len(Dchk) > len(D):
        # the corner pairs of the second-order model: the LMI again with the pairs that P
        # does not contract added (the worst PAIRS_ADDED: 2 certified as much as 8 on the
        # benchmark slope box at 40 % of the cost; all 4^k took seconds per solve)
        worst = np.argsort(_norms(sol.P[0], Dc, T))[::-1][:PAIRS_ADDED]
        again = vertex_lmi(Db + [Dc[i] for i in worst], T, common=True, kappa=k,
                           fallback=scs, reduced=red)
        if again.certified:
            q2, nu2, dP2 = _contraction(again.P[0], Dc, W, Rbar, u_row, loop, T)
            if q2 < q:
                sol, q, nu, dP = again, q2, nu2, dP2
    return sol, W, Wi, q, nu, dP


def _norms(P, Db, T) -> np.ndarray:
    """``||I + T D||_P^2`` of each delta matrix ``D`` of ``Db`` (NumPy)."""
    Lc = np.linalg.cholesky((P + P.T) / 2)
    Linv = np.linalg.inv(Lc)
    out = []
    for Dv in Db:
        Q = Dv.T @ P + P @ Dv + T * Dv.T @ P @ Dv
        out.append(1.0 + T * float(np.linalg.eigvalsh(Linv @ ((Q + Q.T) / 2) @ Linv.T)[-1]))
    return np.array(out)


def _contraction(P, Db, W, Rbar, u_row, loop, T):
    """``(nu + delta_P, nu, delta_P)``: P-norm bound of every LDI sample map (NumPy).

    ``Db`` are the delta matrices in the coordinates ``X_b = W^-1 X``; ``Rbar`` None: no
    remainder (the maps are an enclosure).
    """
    n, rho = P.shape[0], loop.rho
    Lc = np.linalg.cholesky((P + P.T) / 2)
    Linv = np.linalg.inv(Lc)
    nu = math.sqrt(max(float(np.max(_norms(P, Db, T))), 0.0))
    if Rbar is None:
        return nu, nu, 0.0
    keep = loop.keep
    Jp = np.zeros((rho + 1, len(u_row)))
    Jp[:rho, :rho] = np.eye(rho)
    Jp[rho] = u_row
    Jp = Jp[:, keep]
    E = np.zeros((n, rho + 1))
    E[:rho, :rho] = np.eye(rho)
    left = np.abs(Lc.T @ np.linalg.solve(W, E))
    right = np.abs(Jp @ W @ Linv.T)
    dP = float(np.linalg.norm(left @ Rbar @ right, 2))
    return nu + dP, nu, dP


def _room(L, pb) -> dict:
    """``{kept loop index: room}``: the region's room of each ``x_i``, and of ``u``."""
    rho = L.loop.rho
    room = {i: min(pb.xi_op[i] - lo, hi - pb.xi_op[i])
            for i, (lo, hi) in enumerate(pb.xi_region[:rho])}
    rooms_u = [min(pb.u_eq - r[0], r[1] - pb.u_eq) for r in
               (L.design.controller.u_range, pb.input_range) if r is not None]
    if rooms_u:  # the saturation inactive, and u where b was enclosed
        room[L.loop.keep.index(L.loop.names.index("u"))] = min(rooms_u)
    return room


def loop_covered_set(L, point, pb):
    """The covered initial states (:class:`CoveredSet`) of a nonlinear certificate ``point`` of
    the loop ``L``, when the plant's region is known in normal-form coordinates (``pb`` a
    ``PlantBounds`` of a chain plant); else None."""
    if point.kind != "ldi" or pb is None or pb.xi_region is None:
        return None
    names = [L.loop.names[k] for k in L.loop.keep]
    return covered_set(point.lyapunov[0][0], names, pb.xi_op[:L.loop.rho], _room(L, pb))


def widest_covered_set(L, eps: float, gamma: float, pb, G, w):
    """``(CoveredSet, q)`` of a ``P`` chosen for the widest covered starts, or None.

    :func:`._covered_lmi.widest_covered_p` over this LDI's vertices (balanced, else modal
    coordinates; decay rates from the vertices' down to 2 % of it): the first ``P`` that
    re-checks as :func:`ldi_point` does (``q < 1``, remainder included); its sublevel set from
    :func:`covered_set`. ``G`` maps a plant start to the kept loop state, ``w`` is
    the shape of the starts sought.
    """
    from ._covered_lmi import widest_covered_p

    if pb is None or pb.xi_region is None:
        return None
    T, loop = L.T, L.loop
    _, _, _, Rbar, _, _, D, margins, u_row, Dchk = _vertex_loops(L, eps, gamma)
    if np.max(margins) >= 0.0:
        return None
    room = _room(L, pb)
    names = [loop.names[k] for k in loop.keep]
    kappa = DECAY_FRACTION * float(-np.max(margins)) / 2.0
    for W in _coordinates(D):
        Wi = np.linalg.inv(W)
        Db = [Wi @ x @ W for x in D]
        Dc = [Wi @ x @ W for x in Dchk]
        for k in (kappa, 0.25 * kappa, 0.02 * kappa):
            P = widest_covered_p(Db, W, T, k, room, G, w)
            if P is None:
                continue
            try:
                q = _contraction(W.T @ P @ W, Dc, W, Rbar, u_row, loop, T)[0]
            except np.linalg.LinAlgError:
                continue
            if q < 1.0 - RECHECK_TOL:
                return covered_set(P, names, pb.xi_op[:loop.rho], room), q
    return None


__all__ = ["DECAY_FRACTION", "CoveredSet", "covered_set", "ldi_point", "loop_covered_set",
           "widest_covered_set"]
