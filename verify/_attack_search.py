"""Switching attacks on a sampled loop family: which members of a class grow.

A class's members at one ``(eps, gamma)`` are the loops ``M(b_k, a_k)`` with ``b_k`` in its
range (arbitrary from sample to sample, or moving at most ``b_rate`` per sample) and ``a_k`` in
its slope box. Each attack returns a *growth*: a lower bound of the joint spectral radius
(``rho(product)^(1/length)`` of a product of members, > 1 means a periodic member sequence
grows without bound) or the ratio ``||X_N|| / max_(k <= N/2) ||X_k||`` of a trajectory (a
measure that a stable loop's transient peaking cannot fake), with the member sequence that
produced it so that a growth can be re-checked exactly (:mod:`_attack_loop`).

Examples
--------
>>> import numpy as np
>>> A = [np.array([[1.0, 1.0], [0.0, 0.0]]), np.array([[0.0, 0.0], [1.0, 1.0]])]
>>> round(products(A, 2)[0], 6)  # rho(A1 A0) = 1
1.0
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import scipy.linalg


def _radius(P) -> np.ndarray:
    with np.errstate(all="ignore"):
        r = np.max(np.abs(np.linalg.eigvals(P)), axis=-1)
    return np.where(np.isfinite(r), r, np.inf)


def balanced(mats):
    """The vertex matrices under one power-of-2 diagonal similarity (exact): smaller norms,
    better-conditioned eigenvalues; the similarity ``s`` is returned too."""
    mid = sum(mats) / len(mats)
    _, (s, _) = scipy.linalg.matrix_balance(mid, permute=False, separate=True)
    return [m * s[None, :] / s[:, None] for m in mats], s


def products(mats, max_len: int, budget: int = 40000):
    """Largest ``rho(M_(i_k) ... M_(i_1))^(1/k)`` over all products of length ``k <=
    max_len`` (fewer when ``len(mats)^k`` exceeds ``budget``); returns (growth, sequence)."""
    V = np.stack(mats)
    m = len(mats)
    best, seq = -np.inf, ()
    P = V.copy()
    idx = [(i,) for i in range(m)]
    for k in range(1, max_len + 1):
        if k > 1:
            if len(idx) * m > budget:
                break
            P = np.einsum("jab,ibc->ijac", V, P).reshape(-1, *V.shape[1:])
            idx = [s + (j,) for s in idx for j in range(m)]
        r = _radius(P) ** (1.0 / k)
        i = int(np.argmax(r))
        if r[i] > best:
            best, seq = float(r[i]), idx[i]
    return best, seq


#: Longest dwell the refinement tries (samples): beyond, a dwell pair is a frozen loop.
MAX_DWELL = 8192


def dwell_periodic(mats, every: int = 64, dwells=(128, 256, 512, 1024, 2048, 4096, 8192),
                   refine: int = 3):
    """``rho(M_j^q M_i^p)^(1/(p+q))`` over vertex pairs: every ``p, q <= every`` (resonant
    short dwells, e.g. 9:19 samples) and the long ``dwells`` (slow switching) with any
    ``p, q`` of ``1, 2, 4, ..`` or ``dwells``; the ``refine`` best pairs are then polished by
    coordinate steps on ``p`` and ``q`` (halving from the largest power of 2 below them: a
    790:67 period lies between grid points). Returns (growth, (i, p, j, q))."""
    n = mats[0].shape[0]
    short = np.arange(1, every + 1)
    longs = sorted(set([2 ** k for k in range(7)] + list(dwells)))
    pw = []
    for M in mats:  # M^1..M^every, then the long powers
        P = np.empty((every, n, n))
        P[0] = M
        for k in range(1, every):
            P[k] = M @ P[k - 1]
        pw.append((P, {p: np.linalg.matrix_power(M, p) for p in longs}))
    cands = []
    for i, j in itertools.permutations(range(len(mats)), 2):
        prod = np.einsum("qab,pbc->qpac", pw[j][0], pw[i][0])  # [q-1, p-1] = M_j^q M_i^p
        r = _radius(prod) ** (1.0 / (short[:, None] + short[None, :]))
        q, p = np.unravel_index(int(np.argmax(r)), r.shape)
        cands.append((float(r[q, p]), (i, int(p + 1), j, int(q + 1))))
        for p in longs:
            for q in longs:
                if p <= every and q <= every:
                    continue
                g = float(_radius(pw[j][1][q] @ pw[i][1][p])) ** (1.0 / (p + q))
                cands.append((g, (i, p, j, q)))
    cands.sort(key=lambda c: -c[0])
    best = cands[0]
    for g, (i, p, j, q) in cands[:refine]:
        g, p, q = _refine_pair(mats[i], mats[j], p, q, g)
        if g > best[0]:
            best = (g, (i, p, j, q))
    return best


def _refine_pair(A, B, p, q, g):
    """Coordinate ascent of ``rho(B^q A^p)^(1/(p+q))`` over integer ``p, q >= 1``."""
    seen = {}

    def growth(p, q):
        if (p, q) not in seen:
            P = np.linalg.matrix_power(B, q) @ np.linalg.matrix_power(A, p)
            seen[(p, q)] = float(_radius(P)) ** (1.0 / (p + q))
        return seen[(p, q)]

    step = 2 ** int(np.log2(max(p, q, 1)))
    while step >= 1:
        moved = False
        for dp, dq in ((step, 0), (-step, 0), (0, step), (0, -step)):
            if 1 <= p + dp <= MAX_DWELL and 1 <= q + dq <= MAX_DWELL:
                t = growth(p + dp, q + dq)
                if t > g:
                    g, p, q, moved = t, p + dp, q + dq, True
                    break
        if not moved:
            step //= 2
    return g, p, q


def _norm_weight(mats, T):
    """Cholesky factor of the delta-form Lyapunov solution of the middle member (a norm in
    which the frozen middle loop contracts), or None."""
    mid = sum(mats) / len(mats)
    try:
        with warnings.catch_warnings():  # ill-conditioned at rho >= 3: a heuristic norm only
            warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
            P = scipy.linalg.solve_discrete_lyapunov(mid.T, np.eye(mid.shape[0]) * T)
        return np.linalg.cholesky(0.5 * (P + P.T)).T
    except (np.linalg.LinAlgError, ValueError):
        return None


def _traj_growth(norms):
    half = len(norms) // 2
    return float(norms[-1] / max(np.max(norms[: half + 1]), 1e-300))


def _window_radius(mats, seq, windows):
    """Largest ``rho(product over the last w steps of seq)^(1/w)``: a JSR lower bound."""
    best, arg = -np.inf, None
    for w in windows:
        if w > len(seq):
            continue
        r = product_growth(mats, seq[-w:])
        if r > best:
            best, arg = r, tuple(seq[-w:])
    return best, arg


def product_growth(mats, seq) -> float:
    """``rho(M_seq[-1] ... M_seq[0])^(1/len(seq))`` in double, the product renormalized as it
    grows (long sequences neither overflow nor underflow)."""
    logs, P = 0.0, np.eye(mats[0].shape[0])
    for i in seq:
        P = mats[i] @ P
        s = np.max(np.abs(P))
        P /= s
        logs += np.log(s)
    r = float(_radius(P))
    if not r > 0:
        return 0.0
    return float(np.exp((np.log(r) + logs) / len(seq)))


def greedy(mats, T, steps: int, x0s, moves=None, windows=(8, 32, 128, 512)):
    """Greedy worst case: at each step the member maximizing the next state's norm (Euclidean
    and the middle member's Lyapunov norm). ``moves(i)`` lists the members allowed after
    member ``i`` (a rate bound), None: all. Returns (trajectory growth, JSR lower bound from
    windows of the greedy sequence, that sequence)."""
    W = _norm_weight(mats, T)
    weights = [np.eye(mats[0].shape[0])] + ([W] if W is not None else [])
    V = np.stack(mats)
    best_t, best_r, best_seq = -np.inf, -np.inf, ()
    for Wt in weights:
        for x0 in x0s:
            x, i = x0 / np.linalg.norm(x0), None
            seq, norms, logscale = [], [1.0], 0.0
            for _ in range(steps):
                allowed = range(len(mats)) if (moves is None or i is None) else moves(i)
                allowed = list(allowed)
                cand = V[allowed] @ x
                k = int(np.argmax(np.linalg.norm(cand @ Wt.T, axis=1)))
                i = allowed[k]
                x = cand[k]
                s = np.linalg.norm(x)
                if not np.isfinite(s) or s == 0:
                    break
                logscale += np.log(s)
                x = x / s
                seq.append(i)
                norms.append(np.exp(logscale))
            if len(norms) > 2:
                best_t = max(best_t, _traj_growth(np.array(norms)))
            r, arg = _window_radius(mats, seq, windows)
            if r > best_r:
                best_r, best_seq = r, arg
    return best_t, best_r, best_seq


def random_dwell(mats, steps: int, rng, means=(1, 8, 64, 512), runs: int = 2, moves=None):
    """Random member sequences (dwell times geometric with the given means; with ``moves``, a
    random walk of allowed moves): the largest trajectory growth and product radius."""
    n = mats[0].shape[0]
    best_t, best_r, best_seq = -np.inf, -np.inf, ()
    for mean in means:
        for _ in range(runs):
            seq, i = [], int(rng.integers(len(mats)))
            while len(seq) < steps:
                if moves is None:
                    d = int(rng.geometric(1.0 / mean))
                    seq += [i] * d
                    i = int(rng.integers(len(mats)))
                else:
                    opts = list(moves(i))
                    i = opts[int(rng.integers(len(opts)))]
                    seq += [i] * int(rng.geometric(1.0 / mean))
            seq = seq[:steps]
            x = rng.standard_normal(n)
            x /= np.linalg.norm(x)
            norms, logscale = [1.0], 0.0
            for k in seq:
                x = mats[k] @ x
                s = np.linalg.norm(x)
                logscale += np.log(s)
                x /= s
                norms.append(np.exp(logscale))
            g = _traj_growth(np.array(norms))
            best_t = max(best_t, g)
            r = product_growth(mats, seq)
            if r > best_r:
                best_r, best_seq = r, tuple(seq)
    return best_t, best_r, best_seq


def run_patterns(A, B, pairs: int = 3, longest: int = 7):
    """``rho(B^(q_m) A^(p_m) ... B^(q_1) A^(p_1))^(1/sum)`` over every pattern of ``pairs``
    runs of each member, each run 1..``longest`` samples (batched): mixed dwells such as
    5:2, 5:2, 4:2 whose period no product of length 8 and no single dwell pair reaches.
    Returns (growth, sequence of 0 = A, 1 = B)."""
    n = A.shape[0]
    pw = [np.stack([np.linalg.matrix_power(M, k) for k in range(1, longest + 1)])
          for M in (A, B)]
    P, lens = np.eye(n)[None], np.zeros(1, dtype=int)
    runs = np.zeros((1, 0), dtype=int)
    for r in range(2 * pairs):
        Q = pw[r % 2]  # (longest, n, n)
        P = np.einsum("kab,mbc->mkac", Q, P).reshape(-1, n, n)
        lens = (lens[:, None] + np.arange(1, longest + 1)[None, :]).ravel()
        runs = np.concatenate([np.repeat(runs, longest, axis=0),
                               np.tile(np.arange(1, longest + 1), len(runs))[:, None]], axis=1)
    r = _radius(P) ** (1.0 / lens)
    i = int(np.argmax(r))
    seq = [k % 2 for k, c in enumerate(runs[i]) for _ in range(int(c))]
    return float(r[i]), seq


def hill_climb(mats, seq, sweeps: int = 8):
    """Improve a periodic member sequence by single-sample changes (each position to every
    other member, kept when ``rho(period)^(1/len)`` grows): a local maximum-principle search
    from the best sequences of the other attacks. Returns (growth, sequence)."""
    seq = list(seq)
    best = product_growth(mats, seq)
    for _ in range(sweeps):
        improved = False
        for k in range(len(seq)):
            for v in range(len(mats)):
                if v == seq[k]:
                    continue
                trial = seq[:k] + [v] + seq[k + 1:]
                g = product_growth(mats, trial)
                if g > best:
                    best, seq, improved = g, trial, True
        if not improved:
            break
    return best, seq


__all__ = ["balanced", "dwell_periodic", "greedy", "hill_climb", "product_growth", "products",
           "random_dwell", "run_patterns"]
