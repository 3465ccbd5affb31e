"""The step certificate's small conic programs handed to Clarabel directly (no CVXPY).

:func:`._sector.solve_ellipsoid` (the multipliers of one level of ``V``) and
:func:`._start_lmi.widest_start_p` (a ``P`` covering the start) are tiny SDPs (blocks of
order 8 to 16, a few tens of variables) solved a dozen times per step certificate. Through
CVXPY each solve paid ~0.1 s of canonicalization and Clarabel ran on two threads; here, as in
:mod:`._sdp` for the vertex LMIs, each program is written as Clarabel's ``A z + s = b``,
``s`` in a product of cones, by evaluating its affine constraint maps on the unit vectors
(NumPy), and solved with one thread::

    minimize c^T x  subject to  F_k(x) = F_k0 + sum_i x_i F_ki  in  K_k

``K_k`` the zero cone, the non-negative orthant, a second-order cone (``||F[1:]|| <= F[0]``)
or the PSD cone (``F_k`` symmetric, :func:`._sdp.svec`). The answer is a guess like any
solver's: the callers re-check it in NumPy (:func:`._sector.recheck`).

Examples
--------
>>> import numpy as np
>>> # minimize x subject to [[x, 1], [1, x]] >= 0: x = 1
>>> Fi = np.array([[[1.0, 0.0], [0.0, 1.0]]])
>>> r = solve_conic(np.array([1.0]), [("psd", np.array([[0.0, 1.0], [1.0, 0.0]]), Fi)])
>>> r.status, round(float(r.x[0]), 6)
('optimal', 1.0)
"""

from __future__ import annotations

import numpy as np

from ._sdp import MarginSolution, _clarabel, svec, sym_basis

#: Cone kinds of :func:`solve_conic`.
KINDS = ("zero", "nonneg", "soc", "psd")


def solve_conic(c, blocks) -> MarginSolution:
    """Minimize ``c^T x`` subject to ``F_k0 + sum_i x_i F_ki`` in each block's cone.

    Parameters
    ----------
    c : numpy.ndarray
        ``(nvar,)`` objective (zeros: a feasibility problem).
    blocks : sequence of (str, numpy.ndarray, numpy.ndarray)
        ``(kind, F0, Fi)`` with ``kind`` one of :data:`KINDS`; ``F0`` ``(d,)`` and ``Fi``
        ``(nvar, d)`` for a vector cone (``"soc"``: ``||F[1:]|| <= F[0]``), ``F0`` ``(d, d)``
        and ``Fi`` ``(nvar, d, d)`` symmetric for ``"psd"``.

    Returns
    -------
    MarginSolution
        ``x`` (None unless the status is one of :data:`._sdp.WITH_SOLUTION`), ``eta`` the
        objective's value, the status word and Clarabel's iterations. A solver failure is a
        status (``"solver_error: ..."``), never an exception. Counted by
        :func:`._lmi.solve_count`.

    Raises
    ------
    ValueError
        An unknown cone kind or mismatched shapes (a programming error, not a user's input).

    Examples
    --------
    >>> import numpy as np
    >>> # minimize x subject to x >= 1 and ||(1, 1)|| <= x (an SOC): x = sqrt(2)
    >>> soc = ("soc", np.array([0.0, 1.0, 1.0]), np.array([[1.0, 0.0, 0.0]]))
    >>> r = solve_conic(np.array([1.0]), [("nonneg", np.array([-1.0]), np.ones((1, 1))), soc])
    >>> r.status, round(float(r.x[0]), 6)
    ('optimal', 1.414214)
    """
    import clarabel

    from ._lmi import counted

    c = np.asarray(c, dtype=float).ravel()
    nvar = c.size
    rows_a, rows_b, cones = [], [], []
    make = {"zero": clarabel.ZeroConeT, "nonneg": clarabel.NonnegativeConeT,
            "soc": clarabel.SecondOrderConeT}
    for kind, F0, Fi in blocks:
        F0, Fi = np.asarray(F0, dtype=float), np.asarray(Fi, dtype=float)
        if kind not in KINDS or Fi.shape != (nvar,) + F0.shape:
            raise ValueError(f"a block must be one of {KINDS} with F0 (d,) or (d, d) and Fi "
                             f"(nvar, ...) for nvar = {nvar}; got {kind!r}, {F0.shape}, "
                             f"{Fi.shape}")
        if kind == "psd":
            rows_b.append(svec(F0))
            rows_a.append(-svec(Fi).T)
            cones.append(clarabel.PSDTriangleConeT(F0.shape[0]))
        else:
            rows_b.append(F0)
            rows_a.append(-Fi.T)
            cones.append(make[kind](F0.size))
    status, z, iters, _ = counted(_clarabel, c, np.vstack(rows_a), np.concatenate(rows_b),
                                  cones)
    if z is None:
        return MarginSolution(None, None, status, iters)
    return MarginSolution(z, float(c @ z), status, iters)


def ellipsoid_program(ch, Pt, Kt, kappa: float, nbar: float):
    """:func:`._sector.solve_ellipsoid`'s multipliers SDP in the ``P = I`` coordinates.

    The program of the :mod:`._sector` docstring with the slacks it names (``2 kappa``,
    ``1.9 S``, ``mu / 1.1``, each corner form ``<= -1e-7 I``, ``s >= 1e-6``, the rooms times
    ``1 - 1e-6``), the blocks evaluated once per ``P``; ``beta = level^-1/2`` enters only the
    second-order cones and the noise row. Returns ``feasible(beta) -> (s, Z, mu) or None``
    (None unless Clarabel says solved).

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> from fl_design.analysis._sector import loop_channels
    >>> ch = loop_channels(fl.presets.paper_design(), (3.6, 6.8), None)
    >>> n = ch.Ms.shape[1]
    >>> Pt = {"n": n, "D": [(M - np.eye(n)) / ch.T for M in ch.Ms], "B": [B / ch.T for B in ch.Bs],
    ...       "E": [E[:, None] / ch.T for E in ch.Es]}
    >>> ellipsoid_program(ch, Pt, ch.K, 1e-3, 0.0)(1e6) is None  # not even I contracts
    True
    """
    T, n, m = ch.T, Pt["n"], ch.K.shape[0]
    noise = nbar > 0
    nv = m + m * n + (1 if noise else 0)  # s, Z (rows), mu
    k = n + m + (1 if noise else 0)
    i_mu = m + m * n
    coef = np.zeros((nv, k, k))  # the corner forms' coefficients (the same at every corner)
    H = ch.H
    for j in range(m):
        E = np.zeros((m, m))
        E[j, j] = 1.0
        coef[j, n:n + m, n:n + m] = E @ H + H.T @ E - 1.9 * E
        for i in range(n):
            coef[m + j * n + i, n + j, i] = coef[m + j * n + i, i, n + j] = 1.0
    if noise:
        coef[i_mu, n + m, n + m] = -1.0 / 1.1
    psd = []
    for v in range(ch.Ms.shape[0]):
        D, B, E = Pt["D"][v], Pt["B"][v], Pt["E"][v]
        Rn = np.hstack([D] + ([B] if m else []) + ([E] if noise else []))
        A0 = T * (Rn.T @ Rn)
        A0[:n, :n] += D + D.T + 2 * kappa * np.eye(n)
        if m:
            A0[:n, n:n + m] += B
            A0[n:n + m, :n] += B.T
        if noise:
            A0[:n, n + m:] += E
            A0[n + m:, :n] += E.T
        psd.append(("psd", -(A0 + A0.T) / 2 - 1e-7 * np.eye(k), -coef))
    fixed = []
    for j in range(m):  # s_j >= 1e-6
        Fi = np.zeros((nv, 1))
        Fi[j, 0] = 1.0
        fixed.append(("nonneg", np.array([-1e-6]), Fi))
    if noise:
        Fi = np.zeros((nv, 1))
        Fi[i_mu, 0] = 1.0
        fixed.append(("nonneg", np.zeros(1), Fi))
    lims = [(ch.room[j] - abs(ch.kn[j]) * nbar) * (1 - 1e-6) for j in range(m)]
    c = np.zeros(nv)

    def feasible(beta: float):
        cones = []
        for j in range(m):  # ||s_j Kt_j - Z_j|| <= lim_j beta s_j
            Fi = np.zeros((nv, n + 1))
            Fi[j, 0] = lims[j] * beta
            Fi[j, 1:] = Kt[j]
            Fi[m + j * n + np.arange(n), 1 + np.arange(n)] = -1.0
            cones.append(("soc", np.zeros(n + 1), Fi))
        if noise:  # mu nbar^2 beta^2 <= kappa
            Fi = np.zeros((nv, 1))
            Fi[i_mu, 0] = -nbar ** 2 * beta ** 2
            cones.append(("nonneg", np.array([kappa * (1 - 1e-6)]), Fi))
        r = solve_conic(c, fixed + cones + psd)
        if r.status != "optimal" or r.x is None:
            return None
        x = r.x
        return x[:m], x[m:m + m * n].reshape(m, n), float(x[i_mu]) if noise else 0.0

    return feasible


def start_program(Db, T: float, k: float, rows, x0):
    """:func:`._start_lmi.widest_start_p`'s LMI: minimize ``x0^T P x0`` over ``P`` with
    ``[[-(P D + D^T P) - 2 k P, sqrt(T) D^T P], [sqrt(T) P D, P]] >= 0`` at every ``D`` of
    ``Db`` and ``[[P, c], [c^T, r^2]] >= 0`` for every row ``(c, r)`` (the unit set of ``P``
    inside ``|c^T X| <= r``). Returns ``P`` (symmetric; None unless Clarabel gave a solution).

    Examples
    --------
    >>> import numpy as np
    >>> P = start_program([np.array([[-1.0]])], 1e-3, 0.1, [(np.array([1.0]), 2.0)],
    ...                   np.array([1.0]))
    >>> round(float(P[0, 0]), 5)  # the unit set |X| <= 1/sqrt(P) reaches the row's 2
    0.25
    """
    n = x0.size
    Bs = sym_basis(n)
    nb = Bs.shape[0]
    nv = nb + 1  # P's coordinates, then t
    sT = np.sqrt(T)
    blocks = []
    for D in Db:
        Fi = np.zeros((nv, 2 * n, 2 * n))
        BD = Bs @ D
        Fi[:nb, :n, :n] = -(BD + np.swapaxes(BD, -1, -2)) - 2.0 * k * Bs
        Fi[:nb, n:, :n] = sT * BD
        Fi[:nb, :n, n:] = sT * np.swapaxes(BD, -1, -2)
        Fi[:nb, n:, n:] = Bs
        blocks.append(("psd", np.zeros((2 * n, 2 * n)), Fi))
    for cw, r in rows:
        F0 = np.zeros((n + 1, n + 1))
        F0[:n, n] = F0[n, :n] = cw
        F0[n, n] = r * r
        Fi = np.zeros((nv, n + 1, n + 1))
        Fi[:nb, :n, :n] = Bs
        blocks.append(("psd", F0, Fi))
    Fi = np.zeros((nv, 1))
    Fi[:nb, 0] = -np.einsum("i,kij,j->k", x0, Bs, x0)
    Fi[nb, 0] = 1.0
    blocks.append(("nonneg", np.zeros(1), Fi))  # x0^T P x0 <= t
    c = np.zeros(nv)
    c[nb] = 1.0
    r = solve_conic(c, blocks)
    if r.x is None:
        return None
    return np.tensordot(r.x[:nb], Bs, axes=1)


__all__ = ["KINDS", "ellipsoid_program", "solve_conic", "start_program"]
