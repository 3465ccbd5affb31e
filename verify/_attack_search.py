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


def dwell_periodic(mats, dwells=(1, 2, 4, 8, 16, 64, 256, 1024, 4096)):
    """``rho(M_j^q M_i^p)^(1/(p+q))`` over vertex pairs and dwell times: slow switching."""
    pw = {(i, p): np.linalg.matrix_power(M, p) for i, M in enumerate(mats) for p in dwells}
    best, arg = -np.inf, None
    for i, j in itertools.permutations(range(len(mats)), 2):
        for p in dwells:
            for q in dwells:
                r = float(_radius(pw[(j, q)] @ pw[(i, p)])) ** (1.0 / (p + q))
                if r > best:
                    best, arg = r, (i, p, j, q)
    return best, arg


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


__all__ = ["balanced", "dwell_periodic", "greedy", "product_growth", "products", "random_dwell"]
