"""One target of :mod:`attack_certificates`: a class at one ``(eps, gamma)``, every attack.

A member of the class at one sample is ``(t, c)``: ``b = b_lo + t (b_hi - b_lo)`` and the
slope box's corner ``c``; its loop matrix is affine in ``b`` (only the plant's input column
depends on it), so the matrices of the two ends per corner, built by :mod:`_attack_loop`,
give every member exactly (in double for the search, in mpmath to confirm a growth).

Examples
--------
>>> import numpy as np
>>> import fl_design as fl
>>> cls = fl.PlantClass(rho=1, T=1e-3, b=(1.0, 2.0))
>>> d = fl.Design(estimator=fl.EHGO(1, 0.01, 1e-3),
...               controller=fl.DynamicController((1.0,), 0.01))
>>> r = attack_target(d, cls, 0.01, 0.01, "varying", np.random.default_rng(0), False)
>>> r["named class"]["beat"]
False
"""

from __future__ import annotations

import itertools

import mpmath
import numpy as np
from _attack_loop import loop_matrix
from _attack_search import (
    balanced,
    dwell_periodic,
    greedy,
    hill_climb,
    product_growth,
    products,
    random_dwell,
    run_patterns,
)

#: A product radius counts as growth above ``1 + CONFIRM`` (confirmed in mpmath).
CONFIRM = 1e-9
#: A trajectory growing more than this is reported (a beat needs a confirmed product radius).
TRAJ_BEAT = 10.0
DPS = 40


class Members:
    """The class's loops at one ``(eps, gamma)``: double and mpmath matrices of members."""

    def __init__(self, d, cls, eps, gamma):
        self.lo, self.hi = cls.b
        self.corners = ([None] if cls.a_slopes is None
                        else [tuple(c) for c in itertools.product(*cls.a_slopes)])
        g = (1.0 if self.lo > 0 else -1.0) * abs(gamma)
        self.kw = {"rho": d.rho, "T": d.T, "eps": eps, "alphas": d.estimator.alphas,
                   "gains": d.controller.gains, "gamma": g, "ki": d.controller.ki}
        self.ends = [[loop_matrix(b=b, a_row=a, **self.kw) for b in (self.lo, self.hi)]
                     for a in self.corners]
        _, self.s = balanced([m for pair in self.ends for m in pair])
        self._mp = {}

    def matrix(self, t, c):
        """Balanced double matrix of member ``(t, c)``."""
        A0, A1 = self.ends[c]
        M = A0 + t * (A1 - A0)
        return M * self.s[None, :] / self.s[:, None]

    def exact(self, t, c):
        """mpmath matrix of member ``(t, c)`` (affine in ``t`` between the ends, exactly)."""
        if c not in self._mp:
            self._mp[c] = [loop_matrix(b=b, a_row=self.corners[c], exact=True, dps=DPS,
                                       **self.kw) for b in (self.lo, self.hi)]
        A0, A1 = self._mp[c]
        mpmath.mp.dps = DPS
        return A0 + (A1 - A0) * mpmath.mpf(t)


def exact_growth(members: Members, keys, seq) -> float:
    """``rho(product)^(1/len)`` of the member sequence ``seq`` (indices into ``keys``, first
    applied first) in mpmath at :data:`DPS` digits (runs of one member as matrix powers)."""
    old = mpmath.mp.dps
    try:
        mats = {i: members.exact(*keys[i]) for i in set(seq)}
        mpmath.mp.dps = DPS
        P = mpmath.eye(mats[seq[0]].rows)
        for i, run in itertools.groupby(seq):
            P = (mats[i] ** len(list(run))) * P
        ev = mpmath.eig(P, left=False, right=False)
        r = max(abs(e) for e in ev)
        return float(r ** (mpmath.mpf(1) / len(seq)))
    finally:
        mpmath.mp.dps = old


def _record(found, name, growth, seq, keys, members, traj=0.0):
    """Keep the attack's growth (double); :func:`_best` confirms it in mpmath when it is the
    top candidate above 1 + CONFIRM."""
    seq = list(seq)
    found.append({"attack": name, "growth": float(growth), "traj": float(traj),
                  "witness": _describe(seq, keys, members), "seq": seq,
                  "exact": not seq or not growth > 1.0 + CONFIRM,
                  "confirm": lambda: exact_growth(members, keys, seq)})


def _describe(seq, keys, members):
    if not seq:
        return "-"
    runs = [(keys[i], len(list(r))) for i, r in itertools.groupby(seq)]
    text = ", ".join(f"b={members.lo + t * (members.hi - members.lo):.6g}"
                     + ("" if members.corners[c] is None else f" a={members.corners[c]}")
                     + f" x{n}" for (t, c), n in runs[:12])
    return f"[{text}{', ...' if len(runs) > 12 else ''}] ({len(seq)} samples, periodic)"


def frozen(members, full):
    """Constant members: ``b`` on a dense grid (uniform and geometric) x every corner."""
    n = 401 if full else 101
    lo, hi = members.lo, members.hi
    sign = 1.0 if lo > 0 else -1.0
    b = np.union1d(np.linspace(lo, hi, n),
                   sign * np.geomspace(min(abs(lo), abs(hi)), max(abs(lo), abs(hi)), n))
    ts = np.clip((b - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.zeros(1)
    keys = [(float(t), c) for c in range(len(members.corners)) for t in ts]
    M = np.stack([members.matrix(*k) for k in keys])
    r = np.max(np.abs(np.linalg.eigvals(M)), axis=-1)
    i = int(np.argmax(r))
    found = []
    _record(found, "frozen b (and a corner)", r[i], [i], keys, members)
    return found


def switching(members, T, rng, full):
    """Arbitrary switching among the vertices (b ends x corners)."""
    keys = [(t, c) for c in range(len(members.corners)) for t in (0.0, 1.0)]
    mats = [members.matrix(*k) for k in keys]
    found = []
    g, seq = products(mats, 8 if full else 6)
    _record(found, f"products of length <= {8 if full else 6}", g, seq, keys, members)
    g, (i, p, j, q) = dwell_periodic(mats, 128 if len(mats) <= 2 else 32) if full \
        else dwell_periodic(mats, 32, (256, 1024), refine=1)
    _record(found, f"dwell switching {p}:{q}", g, [i] * p + [j] * q, keys, members)
    best = (-np.inf, ())
    for c in range(len(members.corners)):  # mixed dwells of the b ends, each corner
        g, sq = run_patterns(mats[2 * c], mats[2 * c + 1], 3, 7 if full else 5)
        if g > best[0]:
            best = (g, [2 * c + k for k in sq])
    _record(found, f"run patterns (3 pairs of runs <= {7 if full else 5})", best[0], best[1],
            keys, members)
    start = max(found, key=lambda f: f["growth"])["seq"]
    if 0 < len(start) <= 128:
        g, sq = hill_climb(mats, start, 8 if full else 2)
        _record(found, "hill climb from the best period so far", g, sq, keys, members)
    x0s = _starts(mats, rng)
    steps = 12000 if full else 1000
    tg, r, seq = greedy(mats, T, steps, x0s if full else x0s[:2])
    _record(found, "greedy switching", r, seq, keys, members, tg)
    tg, r, seq = random_dwell(mats, steps, rng, runs=2 if full else 1)
    _record(found, "random dwell", r, seq[-512:] if len(seq) > 512 else seq, keys, members, tg)
    return found


def rate_bounded(members, T, db, rng, full):
    """``|b_(k+1) - b_k| <= db`` per sample: ``b`` on a grid of step ``db`` (each corner)."""
    width = members.hi - members.lo
    n = int(np.floor(width / db + 1e-9)) + 1
    ts = np.arange(n) * (db / width) if width > 0 else np.zeros(1)
    keys = [(float(t), 0) for t in ts]
    mats = [members.matrix(*k) for k in keys]
    moves = (lambda i: [j for j in (i - 1, i, i + 1) if 0 <= j < n])
    found = []
    x0s = _starts([mats[0], mats[-1]], rng)
    steps = 12000 if full else 2000
    tg, r, seq = greedy(mats, T, steps, x0s, moves=moves)
    _record(found, "greedy rate-bounded", r, seq, keys, members, tg)
    tg, r, seq = random_dwell(mats, steps, rng, means=(1, 16), runs=1, moves=moves)
    _record(found, "random walk", r, seq[-512:], keys, members, tg)
    best = (-np.inf, ())
    spans = [n - 1] + [w for w in (1, 10, 100, 1000) if w < n - 1]
    for w in spans:
        for i1 in sorted({0, (n - 1 - w) // 2, n - 1 - w}):
            seq = list(range(i1, i1 + w + 1)) + list(range(i1 + w - 1, i1, -1))
            g = product_growth(mats, seq)
            if g > best[0]:
                best = (g, seq)
    _record(found, "triangle waves at the full rate", best[0], best[1], keys, members)
    return found


def _starts(mats, rng):
    """Start states: the dominant eigenvector of each given member (real part), one random."""
    out = []
    for M in mats[:4]:
        w, V = np.linalg.eig(M)
        out.append(np.real(V[:, int(np.argmax(np.abs(w)))]))
    out.append(rng.standard_normal(mats[0].shape[0]))
    return out


def _best(found):
    """The top attack, its growth confirmed: candidates above ``1 + CONFIRM`` are recomputed
    in mpmath, best first, until the top one is exact (or below the threshold)."""
    if not found:
        return {"attack": "none", "growth": -np.inf, "traj": 0.0, "witness": "-",
                "beat": False, "transient": False}
    while True:
        top = max(found, key=lambda f: f["growth"])
        if top["exact"]:
            break
        top["growth"], top["exact"] = float(top["confirm"]()), True
    top = {k: v for k, v in top.items() if k != "confirm"}
    traj = max(f["traj"] for f in found)
    top["traj"] = traj
    # a trajectory's growth alone is no proof at rho >= 3: the loop's Lyapunov matrices have
    # condition numbers ~1e9, so a stable switched loop can amplify a state ~1e4-fold for a
    # while (non-normal transients). A beat is a product of members whose radius exceeds 1,
    # confirmed exactly; a trajectory above TRAJ_BEAT without one is reported as a transient.
    top["beat"] = bool(top["growth"] > 1.0 + CONFIRM)
    top["transient"] = bool(traj > TRAJ_BEAT and not top["beat"])
    return top


def attack_target(d, cls, eps, gamma, covers, rng, full, named_class=None):
    """Every attack at one ``(eps, gamma)``: the best per group ``"stated coverage"`` (the
    members the result's ``covers`` names) and ``"named class"`` (the members of the class the
    result names, ``named_class``; default ``cls``)."""
    m = Members(d, cls, eps, gamma)
    F = frozen(m, full)
    S = switching(m, d.T, rng, full) if cls.b_rate is None or covers in (
        "varying", "nonlinear") else []
    R = (rate_bounded(m, d.T, cls.b_rate, rng, full)
         if cls.b_rate and cls.a_slopes is None else [])
    stated = F + (S if covers in ("varying", "nonlinear") else []) + (
        R if covers == "rate-bounded" else [])
    nc = cls if named_class is None else named_class
    if nc.b_rate is None and not S:
        S = switching(m, d.T, rng, full)
    if nc.b_rate and not R and nc.a_slopes is None:
        R = rate_bounded(m, d.T, nc.b_rate, rng, full)
    named = F + (S if nc.b_rate is None else []) + (R if nc.b_rate else [])
    return {"stated coverage": _best(stated), "named class": _best(named)}


__all__ = ["CONFIRM", "Members", "attack_target", "exact_growth"]
