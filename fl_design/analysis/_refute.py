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
  are multiplied and their eigenvalues computed as stacked arrays (one ``eigvals`` call); the
  best pair is refined by coordinate steps. Pairs are ranked by the growth of their
  eigenvalues other than the floor of a mode common to both ends (:func:`guide_rate`: on the
  TRMS the integrator's ``1 - 5e-7`` per sample, which hid every other eigenvalue below the
  onset and stopped the refinement at 0.1237 instead of 0.1205);
* **maximum principle**: the best dwell pair's period is polished by
  :func:`pontryagin_period` (each sample takes the end that increases the dominant
  eigenvalue to first order; a period that satisfies it is reported as an extremal);
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

import dataclasses
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


def common_modes(M_lo: np.ndarray, M_hi: np.ndarray) -> np.ndarray:
    """Moduli of the eigenvalues the two ends share (to ``1e-9``, relative).

    A mode every ``M(b)`` has alike (the controller's integrator on the TRMS: ``1 - 5e-7``
    per sample) puts a floor ``|mu|^N`` under every period's spectral radius; below the
    onset of growth it hides the other eigenvalues, which say how close a period is.

    Examples
    --------
    >>> import numpy as np
    >>> common_modes(np.diag([0.5, 0.9]), np.diag([0.7, 0.9])).tolist()
    [0.9]
    """
    a, b = np.linalg.eigvals(M_lo), np.linalg.eigvals(M_hi)
    near = np.abs(a[:, None] - b[None, :]) <= 1e-9 * np.maximum(1.0, np.abs(a))[:, None]
    return np.abs(a[np.any(near, axis=1)])


def guide_rate(moduli: np.ndarray, periods: np.ndarray, common: np.ndarray) -> np.ndarray:
    """``log(max |lambda|) / period`` over the eigenvalues that are not a common mode's floor.

    Eigenvalue moduli ``(k, n)`` of ``k`` period maps; an eigenvalue within ``1e-7`` (relative)
    of ``|mu|^period`` for a common mode ``mu`` (:func:`common_modes`) is left out. A guide
    for the search only: a refutation is always judged by the whole spectral radius.

    Examples
    --------
    >>> import numpy as np
    >>> r = guide_rate(np.array([[0.9 ** 4, 0.5]]), np.array([4]), np.array([0.9]))
    >>> bool(np.isclose(r[0], np.log(0.5) / 4))
    True
    """
    mod = np.asarray(moduli, dtype=float)
    per = np.asarray(periods, dtype=float)
    if common.size:
        with np.errstate(all="ignore"):
            floor = np.asarray(common, dtype=float)[None, :] ** per[:, None]
        hit = np.any(np.abs(mod[:, :, None] - floor[:, None, :]) <= 1e-7 * floor[:, None, :],
                     axis=-1)
        mod = np.where(hit, 0.0, mod)
    with np.errstate(all="ignore"):
        rate = np.log(np.max(mod, axis=-1)) / per
    return np.where(np.isfinite(rate), rate, -np.inf)


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

    common = common_modes(M_at(b_lo), M_at(b_hi))

    def rates(pairs):
        """Per-sample growth of each dwell pair (the search's guide, see :func:`guide_rate`)
        and its spectral radius (stacked eigvals)."""
        A = np.stack([_power(sq_lo, a) for a, _ in pairs])
        C = np.stack([_power(sq_hi, c) for _, c in pairs])
        periods = np.array([a + c + n_ramps for a, c in pairs])
        with np.errstate(all="ignore"):
            mod = np.abs(np.linalg.eigvals(C @ down @ A @ up))
        return guide_rate(mod, periods, common), np.max(mod, axis=-1)

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


def _dominant(Ms, seq, common):
    """Period map of ``seq`` (indices into ``Ms``): its guide rate, spectral radius and the
    dominant non-floor eigenpair ``(w, x, y)`` (right ``x``, left ``y``: ``y^H Phi = w y^H``)."""
    n = Ms[0].shape[0]
    Phi = np.eye(n)
    for s in seq:
        Phi = Ms[s] @ Phi
    w, V = np.linalg.eig(Phi)
    mod = np.abs(w)
    rate = float(guide_rate(mod[None], np.array([len(seq)]), common)[0])
    keep = np.ones(n, dtype=bool)
    if common.size:
        floor = common[None, :] ** len(seq)
        keep = ~np.any(np.abs(mod[:, None] - floor) <= 1e-7 * floor, axis=1)
    if not keep.any():
        return rate, float(mod.max()), None
    i = int(np.flatnonzero(keep)[np.argmax(mod[keep])])
    try:
        y = np.linalg.inv(V)[i].conj()
    except np.linalg.LinAlgError:
        return rate, float(mod.max()), None
    return rate, float(mod.max()), (w[i], V[:, i], y)


def pontryagin_period(M_lo: np.ndarray, M_hi: np.ndarray, seq, iters: int = 20):
    """Improve a periodic switching between two ends by the maximum principle.

    For the period map's dominant eigenvalue ``w`` (right ``x``, left ``y``), the first-order
    change of ``w`` when sample ``k`` switches ends is ``y_(k+1)^H (M_hi - M_lo) x_k`` (state
    ``x_k`` propagated forward, costate ``y_(k+1)`` backward); growth is locally largest when
    every sample takes the end with the larger value (bang-bang: ``M(b)`` is affine in ``b``).
    The period is updated so until it is such an extremal or stops improving.

    Parameters
    ----------
    M_lo, M_hi : numpy.ndarray
        The two ends' loop matrices.
    seq : sequence of int
        One period, ``0`` for ``M_lo`` and ``1`` for ``M_hi`` per sample.
    iters : int, optional
        Largest number of updates.

    Returns
    -------
    (list of int, float, int)
        The best period, its spectral radius, and the number of samples violating the
        maximum principle's sign condition (0: the period is an extremal).

    Examples
    --------
    >>> import numpy as np
    >>> A = np.array([[0.0, 2.0], [0.0, 0.0]]) * 0.9 + np.eye(2) * 0.5
    >>> seq, radius, bad = pontryagin_period(A, A.T.copy(), [0, 0, 1, 1])
    >>> radius > 1, bad
    (True, 0)
    """
    Ms = (np.asarray(M_lo, dtype=float), np.asarray(M_hi, dtype=float))
    dM = Ms[1] - Ms[0]
    common = common_modes(*Ms)
    seq = [int(s) for s in seq]
    rate, radius, eig = _dominant(Ms, seq, common)
    bad = -1
    for _ in range(iters):
        if eig is None:
            break
        w, x, y = eig
        X = [x]
        for s in seq[:-1]:
            X.append(Ms[s] @ X[-1])
            X[-1] = X[-1] / np.linalg.norm(X[-1])
        Y = [None] * len(seq)
        yk = y * w
        for k in range(len(seq) - 1, -1, -1):
            Y[k] = yk
            yk = Ms[seq[k]].T @ yk
            yk = yk / np.linalg.norm(yk)
        sw = np.array([np.real(np.vdot(Y[k], dM @ X[k])) for k in range(len(seq))])
        wrong = np.flatnonzero((sw > 0.0) != np.array(seq, dtype=bool))
        bad = int(wrong.size)
        if bad == 0:
            break
        order = wrong[np.argsort(-np.abs(sw[wrong]))]
        m = bad
        while m >= 1:  # all violating samples, else the strongest half, quarter, ...
            new = list(seq)
            for k in order[:m]:
                new[k] = 1 - new[k]
            r2, rad2, eig2 = _dominant(Ms, new, common)
            if r2 > rate:
                break
            m //= 2
        if m < 1:
            break
        seq, rate, radius, eig = new, r2, rad2, eig2
    return seq, radius, bad


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


def _polished(M_at, b_lo: float, b_hi: float, best: Refutation) -> Refutation:
    """:func:`pontryagin_period` from the best periodic switching (jumps only)."""
    seq0 = [int(b == b_hi) for b, n in best.runs for _ in range(n)]
    seq, radius, bad = pontryagin_period(M_at(b_lo), M_at(b_hi), seq0)
    if seq == seq0:
        what = ("a maximum-principle extremal" if bad == 0 else
                f"the maximum principle's sign condition fails at {bad} sample(s)")
        return dataclasses.replace(best, how=f"{best.how} ({what})")
    period = [b_hi if s else b_lo for s in seq]
    return _refutation(radius, period, "maximum principle from the best dwell pair: a "
                       f"{len(period)}-sample bang-bang period"
                       + (", an extremal" if bad == 0 else ""))


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
    if db is None and best.runs and best.period <= 4 * top:
        best = _polished(M_at, b_lo, b_hi, best)
        if best.refuted:
            return best
    greedy = _greedy(M_at, b_lo, b_hi, db, P, x0, steps, windows)
    return greedy if greedy.refuted or not math.isfinite(best.radius) else best


__all__ = ["DWELLS", "GROWTH_TOL", "Refutation", "common_modes", "guide_rate",
           "pontryagin_period", "switching_refutation"]
