"""Counterexamples to stability of the surrogate loop under time-varying ``b``.

A certificate says "stable for every admissible sequence ``b_k``"; a refutation is one
admissible *periodic* sequence whose period map ``Phi = M(b_(N-1)) ... M(b_0)`` has spectral
radius above one: repeating it, the loop grows like ``rho(Phi)^(k/N)`` (an exact statement
about the linear surrogate, no simulation tolerance). Admissible means ``b_k`` in the interval
and, for a rate bound ``db``, ``|b_(k+1) - b_k| <= db`` (the period's wrap-around included).

Two families are searched:

* **periodic switching**: ``n_lo`` samples at ``b_min``, a ramp up, ``n_hi`` samples at
  ``b_max``, a ramp down (ramps of slope ``db``; a jump when ``b`` is arbitrary), for dwell
  pairs on a log grid (1 to 8192 samples). Powers come from repeated squaring and all pairs
  are multiplied and their eigenvalues computed as stacked arrays (one ``eigvals`` call);
* **greedy switching**: from the slowest mode, each sample takes the admissible ``b`` that
  maximizes a quadratic norm of the next state (the modal Lyapunov matrix at the mid ``b``);
  windows of the sequence found are closed into periods and checked as above (when the rate
  bound forbids the wrap-around jump, a ramp back to the window's first ``b`` is appended).

A spectral radius counts as a refutation only above ``1 + GROWTH_TOL``.

Both families close their sequences into periods the same way (:func:`_closed`: the sequence,
then a ramp back to its first ``b`` under a rate bound) and are one search,
:func:`switching_refutation`: periodic first, greedy when that finds no growth.

Examples
--------
>>> import numpy as np
>>> from fl_design.analysis._refute import switching_refutation
>>> A = np.array([[0.0, 2.0], [0.0, 0.0]]) * 0.9 + np.eye(2) * 0.5
>>> B = A.T.copy()
>>> r = switching_refutation(lambda b: A if b < 0.5 else B, 0.0, 1.0, None)
>>> r.refuted, r.radius > 1
(True, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: A period map counts as unstable when its spectral radius exceeds ``1 + GROWTH_TOL``.
GROWTH_TOL = 1e-7
#: Dwell times (samples) of the periodic family.
DWELLS = (0, 1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 768, 1024, 1536, 2048, 4096, 8192)


@dataclass(frozen=True)
class Refutation:
    """The worst admissible period found: its spectral radius and how it was built.

    Parameters
    ----------
    refuted : bool
        ``radius > 1 + GROWTH_TOL``.
    radius : float
        Spectral radius of the period map (NaN when nothing was searched).
    period : int
        Samples per period.
    how : str
        The sequence in words (e.g. ``"periodic: 539 samples at b = 3.6, 453 at 6.8"``).
    runs : tuple of (float, int)
        One period as runs ``(b, samples)`` in time order (``b_0`` first): anyone can rebuild
        the period map and check its spectral radius.

    Examples
    --------
    >>> Refutation(False, 0.5, 2, "x", ((1.0, 2),)).refuted
    False
    """

    refuted: bool
    radius: float
    period: int
    how: str
    runs: tuple = ()


def _runs(seq) -> tuple:
    """Run-length encoding ``((b, n), ...)`` of a sequence of b values."""
    out: list = []
    for b in seq:
        b = float(b)
        if out and out[-1][0] == b:
            out[-1][1] += 1
        else:
            out.append([b, 1])
    return tuple((b, n) for b, n in out)


def _ramp_values(b_from: float, b_to: float, db: float | None) -> list:
    if db is None or b_from == b_to:
        return []
    steps = max(1, math.ceil(abs(b_to - b_from) / db * (1 + 1e-12)))
    return [float(v) for v in np.linspace(b_from, b_to, steps + 1)[1:]]


def _squares(M: np.ndarray, top: int) -> list[np.ndarray]:
    """``[M, M^2, M^4, ...]`` up to the largest power of two ``<= top``."""
    sq, k = [M], 1
    while 2 * k <= top:
        sq.append(sq[-1] @ sq[-1])
        k *= 2
    return sq


def _power(sq: list[np.ndarray], n: int) -> np.ndarray:
    """``M^n`` from the squares of :func:`_squares` (binary expansion of ``n``)."""
    acc, j = np.eye(sq[0].shape[0]), 0
    while n:
        if n & 1:
            acc = sq[j] @ acc
        n >>= 1
        j += 1
    return acc


def _closed(part: list, db: float | None) -> list:
    """``part`` closed into a period: a ramp of slope ``db`` back to ``part[0]`` appended."""
    return list(part) + _ramp_values(part[-1], part[0], db)


def _refutation(radius: float, seq: list, how: str) -> Refutation:
    """The :class:`Refutation` of the period ``seq`` whose map has spectral radius ``radius``."""
    return Refutation(bool(radius > 1.0 + GROWTH_TOL), float(radius), len(seq),
                      f"{how}; spectral radius of the period {radius:.9f}", _runs(seq))


def _periodic(M_at, b_lo: float, b_hi: float, db: float | None, top: int) -> Refutation:
    """Worst period ``M_hi^c R_down M_lo^a R_up`` over the dwell grid (stacked eigvals)."""
    n = M_at(b_lo).shape[0]
    up_values, down_values = _ramp_values(b_lo, b_hi, db), _ramp_values(b_hi, b_lo, db)
    up, down = np.eye(n), np.eye(n)
    for b in up_values:
        up = M_at(b) @ up
    for b in down_values:
        down = M_at(b) @ down
    n_ramps = len(up_values) + len(down_values)
    sq_lo, sq_hi = _squares(M_at(b_lo), 2 * top), _squares(M_at(b_hi), 2 * top)

    def rates(pairs):
        """Per-sample growth ``log(rho) / period`` of each dwell pair (stacked eigvals)."""
        A = np.stack([_power(sq_lo, a) for a, _ in pairs])
        C = np.stack([_power(sq_hi, c) for _, c in pairs])
        with np.errstate(all="ignore"):
            rad = np.max(np.abs(np.linalg.eigvals(C @ down @ A @ up)), axis=-1)
            rate = np.log(rad) / np.array([a + c + n_ramps for a, c in pairs])
        return np.where(np.isfinite(rate), rate, -np.inf), rad

    pairs = [(a, c) for a in DWELLS for c in DWELLS
             if a <= top and c <= top and a + c + n_ramps > 0]
    rate, rad = rates(pairs)
    i = int(np.argmax(rate))
    (a, c), best, radius = pairs[i], float(rate[i]), float(rad[i])
    step = max(a, c) // 4
    while step >= 1:  # coordinate refinement of the best dwell pair (stacked candidates)
        cand = [(a + da, c + dc) for da in (-step, 0, step) for dc in (-step, 0, step)
                if 0 <= a + da <= 2 * top and 0 <= c + dc <= 2 * top
                and a + da + c + dc + n_ramps > 0]
        r, rd = rates(cand)
        k = int(np.argmax(r))
        if r[k] > best:
            (a, c), best, radius = cand[k], float(r[k]), float(rd[k])
        else:
            step //= 2
    ramps = "" if db is None else f", ramps of {len(up_values)} samples (|db| <= {db:.4g})"
    seq = [b_lo] * a + up_values + [b_hi] * c + down_values
    return _refutation(radius, seq, f"periodic: {a} samples at b = {b_lo:.6g}, {c} at "
                       f"b = {b_hi:.6g}{ramps}")


def _greedy(M_at, b_lo: float, b_hi: float, db: float | None, P, x0, steps: int,
            windows) -> Refutation:
    """Greedy admissible sequence maximizing ``x^T P x`` each sample, windows closed."""
    x, b, seq = np.asarray(x0, dtype=float), 0.5 * (b_lo + b_hi), []
    cache: dict[float, np.ndarray] = {}

    def mat(v):
        if v not in cache:
            cache[v] = M_at(v)
        return cache[v]

    for _ in range(steps):
        cands = ((b_lo, b_hi) if db is None else
                 tuple({max(b_lo, b - db), b, min(b_hi, b + db)}))
        nxt = [mat(float(c)) @ x for c in cands]
        k = int(np.argmax([v @ P @ v for v in nxt]))
        b, x = float(cands[k]), nxt[k]
        x = x / max(np.linalg.norm(x), 1e-300)
        seq.append(b)
    best = Refutation(False, math.nan, 0, "greedy: nothing searched")
    for w in windows:
        if w > len(seq):
            continue
        period = _closed(seq[-w:], db)
        acc = np.eye(len(x))
        for v in period:
            acc = mat(v) @ acc
        rad = float(np.max(np.abs(np.linalg.eigvals(acc))))
        if not math.isfinite(best.radius) or rad > best.radius:
            best = _refutation(rad, period, f"greedy: a {len(period)}-sample window of the "
                               "greedy sequence, repeated")
    return best


def switching_refutation(M_at, b_lo: float, b_hi: float, db: float | None, *, P=None,
                         x0=None, top: int = DWELLS[-1], steps: int = 6000,
                         windows=(500, 1000, 2000, 4000)) -> Refutation:
    """Search an admissible periodic switching of ``b`` whose period map grows.

    The periodic family (dwell pairs at the ends of the interval, ramps under a rate bound)
    first; when it finds no growth and ``P`` and ``x0`` are given, the greedy family (each
    sample the admissible ``b`` maximizing ``x^T P x``, windows closed into periods).

    Parameters
    ----------
    M_at : callable
        ``b -> M(b)``, the loop matrix at ``b``.
    b_lo, b_hi : float
        The interval.
    db : float or None
        Rate bound per sample (None: ``b`` jumps between the ends).
    P : numpy.ndarray, optional
        The quadratic norm the greedy family maximizes (no greedy search without it).
    x0 : numpy.ndarray, optional
        Start state of the greedy run (required with ``P``).
    top : int, optional
        Longest dwell of the periodic family.
    steps : int, optional
        Length of the greedy run.
    windows : sequence of int, optional
        Lengths of the final greedy windows closed into periods.

    Returns
    -------
    Refutation
        The refuting period, else the worst period found (periodic when greedy found no
        finite radius).

    Examples
    --------
    >>> import numpy as np
    >>> M = np.diag([0.5, 0.9])
    >>> switching_refutation(lambda b: M, 1.0, 2.0, None, P=np.eye(2), x0=np.ones(2)).refuted
    False
    """
    best = _periodic(M_at, b_lo, b_hi, db, top)
    if best.refuted or P is None:
        return best
    greedy = _greedy(M_at, b_lo, b_hi, db, P, x0, steps, windows)
    return greedy if greedy.refuted or not math.isfinite(best.radius) else best


__all__ = ["DWELLS", "GROWTH_TOL", "Refutation", "switching_refutation"]
