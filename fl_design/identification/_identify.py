"""From a rig's log to a plant class with its confidence: :func:`identify`.

Any controller's log works (the ``u`` column is what was applied). What comes out, and how:

* ``T`` and its jitter from the time stamps (:mod:`._log`, which also refuses or counts bad rows);
* the sensor noise's std and spectrum from the output's high-frequency residual (:mod:`._noise`),
  and the quantization step when ``y`` sits on a grid;
* the input delay (samples) by least-squares cross-correlation of ``y`` with the delayed input's
  chain response, and its confidence (:func:`._estimators.find_delay`);
* ``b`` per window by two named estimators (``local-ls`` and ``ehgo-sigmahat``,
  :mod:`._estimators`), each with standard errors; a window is *informative* when its ``b`` is
  known within :data:`REL_SE`; each estimator's range over the visited states is the span of
  ``b +- CONFIDENCE se`` over its informative windows; the class's ``b`` is the union of both
  ranges widened by :data:`MARGIN` (a log sees only the states it visited), and a disagreement
  (medians more than 25 % apart, or disjoint ranges) is reported;
* an excitation check: too few informative windows is an
  :class:`~fl_design.errors.ExcitationError` saying which experiment would do (a square wave
  on the input, sized from the noise and the window).

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim._rig import chain_rig
>>> rig = chain_rig(2, b=5.0, T=1e-3, noise_std=1e-3)
>>> design = fl.tune(fl.PlantClass(rho=2, T=1e-3, b=(2, 10)), reference=1.0).design
>>> log = rig.run(design, lambda t: 1.0 * ((t // 2) % 2), 20.0, seed=2)
>>> cls = fl.identify(log.columns(), rho=2)
>>> cls.source, cls.b[0] <= 5.0 <= cls.b[1], cls.delay
('log', True, 0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import _validate as V
from .._json import jsonable
from ..analysis._plant_class import PlantClass
from ..errors import ExcitationError, LogError
from ._estimators import chain_response, ehgo_sigmahat, find_delay, local_ls, slope_regressors
from ._log import read_log
from ._noise import noise_spectrum, noise_std

#: A window is informative when its b's standard error is at most this fraction of |b|.
REL_SE = 0.1
#: Half-width of each window's interval, in standard errors.
CONFIDENCE = 3.0
#: The class's b range is the estimators' union divided / multiplied by this.
MARGIN = 1.25
#: Default window [s] for rho <= 2 (doubled per order above: the input's trace in y shrinks
#: as (window)^rho).
WINDOW = 0.25
#: Fewest informative windows.
MIN_INFORMATIVE = 4
#: The slopes of ``a`` in ``y, y', ...`` are fitted per window (:func:`._estimators.slope_regressors`)
#: when they cut the windows' residual by this factor: ``a`` then varies within a window (a DC
#: motor's back-EMF, -63 /s under a PI loop: without them b came out -87 .. -624 for a true
#: +1250, and the delay 20 samples for 0); chance alone cuts it by about ``rho / window``.
SLOPE_GAIN = 1.05
#: Steady windows of the log needed to estimate ``u_eq``.
MIN_STEADY = 3
#: A fraction of samples at one value of u above this is "saturated throughout".
SATURATED = 0.95


@dataclass(frozen=True, repr=False)
class Evidence:
    """How the identified class was obtained, and how sure it is (see the module).

    Attributes hold numbers; :meth:`lines` says them in words, :meth:`to_dict` as JSON.
    """

    source: str
    n: int
    duration: float
    T: float
    jitter: float
    jitter_max: float
    skipped: dict
    first_skipped: dict
    noise_std: float
    quantization: float | None
    spectrum: dict
    delay: int
    delay_confidence: float
    window: int
    estimators: dict
    windows: dict
    agreement: bool
    agreement_text: str
    excitation_text: str
    u_range: tuple
    y_range: tuple
    command: str
    warnings: tuple = ()
    a_model: str = ""
    log: Any = field(default=None, compare=False)

    def lines(self) -> list[str]:
        out = [f"log {self.source}: {self.n} samples, {self.duration:.4g} s",
               (f"T = {self.T:.6g} s from the time stamps (jitter std {self.jitter:.3g} s, "
                f"largest {self.jitter_max:.3g} s)")]
        if self.skipped:
            out.append("skipped: " + "; ".join(f"{n} x {why} (first at {self.first_skipped[why]})"
                                             for why, n in self.skipped.items()))
        else:
            out.append("skipped: none")
        q = f", quantization step {self.quantization:.3g}" if self.quantization else ""
        out.append(f"sensor noise std {self.noise_std:.3g} (from the high-order differences "
                   f"of y{q}); spectrum whiteness {self.spectrum.get('whiteness', math.nan):.2f}"
                   " (1 = white)")
        out.append(f"input delay {self.delay} sample(s) (least-squares cross-correlation; the "
                   f"nearest other lag fits {self.delay_confidence:.4g}x worse)")
        if self.a_model:
            out.append(self.a_model)
        for name, e in self.estimators.items():
            if e["n_informative"]:
                out.append(f"b by {name}: [{e['b_lo']:.4g}, {e['b_hi']:.4g}] (median "
                           f"{e['median']:.4g}, {e['n_informative']}/{e['n_windows']} windows "
                           f"informative, +-{CONFIDENCE:g} standard errors)")
            else:
                out.append(f"b by {name}: no informative window of {e['n_windows']}")
        out += [self.agreement_text, self.excitation_text, *self.warnings,
                f"next: {self.command}"]
        return out

    def __repr__(self) -> str:
        return "Evidence\n  " + "\n  ".join(self.lines())

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in self.__dataclass_fields__ if k not in ("log",
                                                                                  "windows")}
        d["spectrum"] = {k: (list(np.asarray(v, dtype=float)) if np.ndim(v) else v)
                         for k, v in self.spectrum.items()}
        d["lines"] = self.lines()
        return jsonable(d)


@dataclass(frozen=True)
class IdentifiedClass(PlantClass):
    """A :class:`fl_design.PlantClass` read from a log, with its :class:`Evidence`."""

    evidence: Any = field(default=None, compare=False, repr=False)

    def to_dict(self) -> dict:
        ev = self.evidence
        d = PlantClass.to_dict(replace(self, evidence=None))
        d["evidence"] = None if ev is None else ev.to_dict()
        return d


def _quantization(y: np.ndarray) -> float | None:
    d = np.abs(np.diff(y))
    d = d[d > 0]
    if d.size < 50:
        return None
    q = float(np.min(d))
    k = d / q
    return q if np.mean(np.abs(k - np.round(k)) < 1e-3) > 0.99 and q > 0 else None


def _check_input(u: np.ndarray, where: str, u_limits) -> None:
    lo, hi = float(np.min(u)), float(np.max(u))
    if hi - lo == 0.0:
        raise ExcitationError(
            f"{where}: the column 'u' is constant ({lo:.6g}) over the whole log: it says nothing "
            f"about b. Experiment: add a square wave on u around its operating value (or steps "
            f"of the reference) and log again")
    tol = 1e-9 * max(1.0, abs(lo), abs(hi))
    ends = [(lo, np.mean(np.abs(u - lo) <= tol)), (hi, np.mean(np.abs(u - hi) <= tol))]
    if u_limits is not None:
        ends += [(v, np.mean(np.abs(u - v) <= tol)) for v in u_limits]
    for v, frac in ends:
        if frac >= SATURATED:
            raise LogError(f"{where}: the column 'u' sits at {v:.6g} in {100 * frac:.1f} % of "
                           f"the samples: saturated throughout, the loop was open. Log with the "
                           f"input inside its limits (a smaller reference step, a slower loop)")


def _summary(est, rel: float) -> dict:
    ok = est.informative(rel)
    if not ok.any():
        return {"n_informative": 0, "n_windows": int(est.b.size), "b_lo": None, "b_hi": None,
                "median": None, "median_rel_se": None}
    b, se = est.b[ok], est.se[ok]
    return {"n_informative": int(ok.sum()), "n_windows": int(est.b.size),
            "b_lo": float(np.min(b - CONFIDENCE * se)), "b_hi": float(np.max(b + CONFIDENCE * se)),
            "median": float(np.median(b)), "median_rel_se": float(np.median(se / np.abs(b)))}


def _experiment(noise: float, T: float, n_win: int, rho: int, b_guess: float | None) -> str:
    """The square wave on u that would make a window informative (sized numerically)."""
    from ._estimators import _poly_basis

    k = np.arange(n_win)
    sq = np.where((k // max(1, n_win // 4)) % 2 == 0, 1.0, -1.0)
    U = chain_response(sq, T, rho, 0)
    Q = _poly_basis(n_win, rho + 1)
    perp = float(np.linalg.norm(U - Q @ (Q.T @ U)))
    need = noise * math.sqrt(1.0) / (REL_SE / 3.0) / perp
    per = f"{need / abs(b_guess):.3g}" if b_guess else f"{need:.3g} / |b|"
    return (f"Experiment: a square wave on u of amplitude >= {per} (period {n_win / 2 * T:.3g} "
            f"s, i.e. 4 switches per {n_win * T:.3g} s window) around the operating input, for "
            f"at least {MIN_INFORMATIVE * n_win * T:.3g} s, within the input limits (or "
            f"reference steps of that effect)")


def _u_eq(L, op: float, sigma: float, n_win: int, u_lim) -> tuple[float | None, str]:
    """The input holding ``y`` at ``op``, from the log's steady windows (``y`` drifting less than
    three noise standard deviations over the window): the mean ``u`` against the mean ``y`` of
    those windows, a line through them read at ``op`` (their median when they sit at one ``y``);
    None when fewer than :data:`MIN_STEADY` windows are steady or ``op`` lies outside them."""
    ys, us = [], []
    for a, b in L.segments:
        for k in range(a, b - n_win + 1, max(1, n_win // 2)):
            y, u = L.y[k:k + n_win], L.u[k:k + n_win]
            tau = np.arange(n_win) - (n_win - 1) / 2.0
            drift = abs(float(tau @ (y - y.mean())) / float(tau @ tau)) * n_win
            if drift <= 3.0 * sigma:
                ys.append(float(y.mean()))
                us.append(float(u.mean()))
    ys, us = np.asarray(ys), np.asarray(us)
    if ys.size < MIN_STEADY:
        return None, (f"u_eq not estimated: {ys.size} steady window(s) of y (at least "
                      f"{MIN_STEADY} needed): give u_eq, the input holding y at {op:.4g}")
    lo, hi = float(ys.min()), float(ys.max())
    if not lo - 3.0 * sigma <= op <= hi + 3.0 * sigma:
        return None, (f"u_eq not estimated: y rested in [{lo:.4g}, {hi:.4g}] only, not at the "
                      f"operating point {op:.4g}: give u_eq")
    if hi - lo <= 6.0 * sigma:
        val = float(np.median(us))
    else:
        slope, icpt = np.polyfit(ys, us, 1)
        val = float(slope * op + icpt)
    if u_lim is not None and not u_lim[0] <= val <= u_lim[1]:
        return None, (f"u_eq not estimated: the steady windows give {val:.4g}, outside u_limits "
                      f"[{u_lim[0]:.4g}, {u_lim[1]:.4g}]")
    return val, (f"u_eq = {val:.4g}: the input holding y at {op:.4g}, from {ys.size} steady "
                 f"windows (y in [{lo:.4g}, {hi:.4g}], drifting < 3 noise std)")


def _delay_and_a_model(L, n_win: int, rho: int, max_delay: int):
    """``(delay, confidence, Z, text)``: the delay of the better local model, ``a`` a polynomial
    in time over a window or with its slopes in ``y, y', ...`` too (``Z``; :data:`SLOPE_GAIN`)."""
    Z = slope_regressors(L.y, L.T, rho)
    found = {}
    for key, z in (("plain", None), ("slopes", Z)):
        if max_delay > 0:
            d, conf, costs = find_delay(L.y, L.u, L.segments, n_win, rho, L.T, max_delay, z)
            cost = float(np.min(costs))
        else:
            d, conf = 0, math.inf
            U = chain_response(L.u, L.T, rho, 0)
            r = local_ls(L.y, U, L.segments, n_win, rho, z).residual
            cost = float(np.sum(r[np.isfinite(r)] ** 2))
        found[key] = (d, conf, cost)
    (d0, c0, e0), (d1, c1, e1) = found["plain"], found["slopes"]
    gain = e0 / e1 if e1 > 0 else (1.0 if e0 == 0 else math.inf)
    if gain > SLOPE_GAIN:
        names = ", ".join("y" + "'" * i for i in range(rho))
        return d1, c1, Z, (f"a varies within a window: its slopes in {names} fitted per "
                           f"window (they cut the residual "
                           f"{gain:.3g}x; without them the delay would be {d0})")
    return d0, c0, None, (f"a as a polynomial in time over each window (fitting its slopes "
                          f"in y too cuts the residual only {gain:.4g}x)")


def identify(log, rho: int, *, T: float | None = None, bad_rows: str = "error",
             b_sign: int | None = None, window: float | None = None, max_delay: int = 20,
             u_limits=None, name: str | None = None) -> IdentifiedClass:
    """Identify a plant class (with its evidence) from a rig's log (see the module).

    Parameters
    ----------
    log : str, pathlib.Path or mapping
        CSV file with a header ``t, y, u`` (``r`` optional), or a mapping of those columns.
    rho : int
        The relative degree you know.
    T : float, optional
        The sampling time you expect; the time stamps must agree (else a units error).
    bad_rows : {"error", "skip"}, optional
        Unusable rows: an error naming the first (default), or skipped and counted.
    b_sign : {+1, -1}, optional
        The sign of ``b`` you know; a log saying otherwise is an error.
    window : float, optional
        Window length [s] (default :data:`WINDOW` = 0.25 s, doubled per order above 2; at
        least ``20 (rho + 3)`` samples).
    max_delay : int, optional
        Largest input delay searched [samples] (default 20).
    u_limits : (float, float), optional
        The actuator's limits (a log cannot know them; they go into the class).
    name : str, optional
        The class's name (default the file's stem).

    Returns
    -------
    IdentifiedClass
        A :class:`fl_design.PlantClass` (``source="log"``) with ``.evidence``.

    Raises
    ------
    LogError
        The log cannot be used (columns, rows, units, saturated, ``b`` of the wrong or mixed
        sign): the message names the row or column and what is needed.
    ExcitationError
        Too few informative windows: the message says which experiment would do.

    Examples
    --------
    >>> import numpy as np, fl_design as fl
    >>> t = np.arange(4000) * 1e-3
    >>> try:  # a log whose input never moves says nothing about b
    ...     fl.identify({"t": t, "y": np.sin(t), "u": np.ones_like(t)}, rho=2)
    ... except fl.errors.ExcitationError as err:
    ...     print(str(err)[:60])
    <columns>: the column 'u' is constant (1) over the whole log
    """
    rho = V.integer("rho", rho, minimum=1, maximum=8)
    if b_sign not in (None, 1, -1):
        raise LogError(f"b_sign={b_sign!r}: give +1, -1 or None")
    L = read_log(log, bad_rows=bad_rows, T=T)
    u_lim = None if u_limits is None else V.interval("u_limits", u_limits, allow_none=False)
    _check_input(L.u, L.source, u_lim)
    win_s = WINDOW * 2.0 ** max(rho - 2, 0) if window is None else V.positive("window", window)
    n_win = round(win_s / L.T)
    n_win = max(n_win, 20 * (rho + 3))
    if L.n < 2 * n_win:
        raise LogError(f"{L.source}: {L.n} samples make fewer than two windows of {n_win} "
                       f"samples ({n_win * L.T:.3g} s): log at least {4 * n_win * L.T:.3g} s")
    sigma = noise_std(L.y, rho, L.segments)
    spectrum = noise_spectrum(L.y, rho, L.T, L.segments)
    q = _quantization(L.y)
    delay, d_conf, Z, a_model = _delay_and_a_model(L, n_win, rho, max_delay)
    U = chain_response(L.u, L.T, rho, delay)
    est = {"local-ls": local_ls(L.y, U, L.segments, n_win, rho, Z),
           "ehgo-sigmahat": ehgo_sigmahat(L.y, U, L.segments, n_win, rho, L.T, 20.0 * L.T, Z)}
    summ = {k: _summary(e, REL_SE) for k, e in est.items()}
    main = summ["local-ls"]
    need = max(MIN_INFORMATIVE, 1)
    guess = main["median"] or summ["ehgo-sigmahat"]["median"]
    if main["n_informative"] < need:
        raise ExcitationError(
            f"{L.source}: the log does not excite the loop enough: {main['n_informative']} of "
            f"{main['n_windows']} windows ({n_win * L.T:.3g} s each) know b within "
            f"{100 * REL_SE:g} % (at least {need} needed); the input varies too little against "
            f"the sensor noise ({sigma:.3g}). "
            + _experiment(max(sigma, 1e-12), L.T, n_win, rho, guess))
    used = [s for s in summ.values() if s["n_informative"]]
    lo = min(s["b_lo"] for s in used)
    hi = max(s["b_hi"] for s in used)
    signs = {k: np.sign(e.b[e.informative(REL_SE)]) for k, e in est.items()}
    allsign = np.concatenate(list(signs.values()))
    if np.any(allsign > 0) and np.any(allsign < 0) or lo <= 0.0 <= hi:
        raise LogError(f"{L.source}: b changes sign across the log (windows give b from "
                       f"{lo:.4g} to {hi:.4g}): the method needs b of one sign on the region; "
                       f"log a smaller region, or check that u is the applied input")
    sign = 1 if lo > 0 else -1
    if b_sign is not None and sign != b_sign:
        raise LogError(f"{L.source}: the log gives b {'> 0' if sign > 0 else '< 0'} (b in "
                       f"[{lo:.4g}, {hi:.4g}]) but b_sign = {b_sign:+d}: is u's sign flipped "
                       f"(actuator wiring, a negated column)?")
    a, b = sorted((abs(lo), abs(hi)))
    b_cls = (sign * a / MARGIN, sign * b * MARGIN)
    b_cls = tuple(sorted(b_cls))
    s1, s2 = summ["local-ls"], summ["ehgo-sigmahat"]
    if s2["n_informative"] == 0:
        agree, text = False, ("estimators: only local-ls informative (ehgo-sigmahat has no "
                              "informative window): the range rests on one estimator")
    else:
        ratio = s1["median"] / s2["median"]
        disjoint = s1["b_hi"] < s2["b_lo"] or s2["b_hi"] < s1["b_lo"]
        agree = 0.8 <= ratio <= 1.25 and not disjoint
        text = (f"estimators {'agree' if agree else 'DISAGREE'}: medians local-ls "
                f"{s1['median']:.4g}, ehgo-sigmahat {s2['median']:.4g} (ratio {ratio:.3g})"
                + ("; ranges disjoint" if disjoint else "")
                + ("" if agree else ": the class takes the union; log more excitation to "
                   "settle it"))
    exc = (f"excitation: {s1['n_informative']}/{s1['n_windows']} windows informative "
           f"(b within {100 * REL_SE:g} %)")
    warns = []
    if L.jitter > 0.05 * L.T:
        warns.append(f"timing jitter {L.jitter:.3g} s is {100 * L.jitter / L.T:.3g} % of T: "
                     "the class assumes uniform sampling")
    if L.u.size and u_lim is None:
        warns.append(f"u ranged over [{L.u.min():.4g}, {L.u.max():.4g}]; the actuator limits "
                     "are not in a log: give u_limits")
    stem = name or (Path(L.source).stem if L.source != "<columns>" else "log")
    cmd = (f"fl-design identify {L.source} --rho {rho} --out DIR writes DIR/class.toml; then "
           f"`fl-design run DIR/class.toml` designs from it (API: fl.tune(cls))")
    y_range = (float(np.min(L.y)), float(np.max(L.y)))
    ev = Evidence(source=L.source, n=L.n, duration=L.duration, T=L.T, jitter=L.jitter,
                  jitter_max=L.jitter_max, skipped=dict(L.skipped),
                  first_skipped=dict(L.first_skipped), noise_std=sigma, quantization=q,
                  spectrum=spectrum, delay=int(delay), delay_confidence=float(d_conf),
                  window=n_win, estimators=summ, windows=est, agreement=agree,
                  agreement_text=text, excitation_text=exc,
                  u_range=(float(L.u.min()), float(L.u.max())), y_range=y_range,
                  command=cmd, warnings=tuple(warns), a_model=a_model, log=L)
    op = float(np.median(L.r)) if L.r is not None else float(np.median(L.y))
    u_eq, u_eq_text = _u_eq(L, op, sigma, n_win, u_lim)
    notes = ((f"b over the visited states y in [{y_range[0]:.4g}, {y_range[1]:.4g}] by local-ls "
             f"and ehgo-sigmahat (union, +-{CONFIDENCE:g} se, x{MARGIN:g} margin)"),
             text, exc,
             ("a (the drift of y^(rho)) is not bounded from the log: the class is the chain's "
             "(a = 0, no slope box); a certificate of it does not cover the plant's a(x), the "
             "member runs and the rig check it empirically"), u_eq_text)
    return IdentifiedClass(rho=rho, T=L.T, b=b_cls, delay=int(delay), noise_std=sigma,
                           u_limits=u_lim, y_range=y_range, source="log", name=stem,
                           notes=notes, operating_point=op, u_eq=u_eq, evidence=ev)


__all__ = ["Evidence", "IdentifiedClass", "identify"]
