"""Short forms: every verdict and certificate as a status word and the two or three numbers
that matter (``converging — overshoot 45 %, in the band at ~313 s``).

The summary, the console and the figures' legends use these; the long reason (a run's
:meth:`~fl_design.Response.verdict`, a certificate's lines) stays one section (or one click)
away. A :class:`Brief` carries a level (``good``, ``warn``, ``bad``, ``info``) that the HTML
report turns into a coloured badge; the word itself says the same in greyscale.

Examples
--------
>>> from fl_design.app._brief import Brief
>>> str(Brief("converging", "good", "overshoot 45 %, in the band at ~313 s"))
'converging — overshoot 45 %, in the band at ~313 s'
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ._text import REACHES, fmt, no_step, step_reach

#: Most words of a short form (the summary's cells).
MAX_WORDS = 25
#: The separator between the status word and its numbers.
DASH = "—"

_LEVEL = {"converged": "good", "converging": "good", "undecided": "warn", "stalled": "warn",
          "oscillating": "bad", "diverged": "bad", "solver_failed": "bad"}


@dataclass(frozen=True)
class Brief:
    """A status word, its level (the colour) and the few numbers behind it.

    Parameters
    ----------
    word : str
        The status (``converging``, ``certified``, ``PASSED`` ...).
    level : str
        ``good``, ``warn``, ``bad`` or ``info``.
    detail : str, optional
        Two or three numbers in words.
    long : str, optional
        The whole reason (shown one click away in HTML, in its section in Markdown).

    Examples
    --------
    >>> from fl_design.app._brief import Brief
    >>> Brief("x", "info").words()
    1
    """

    word: str
    level: str
    detail: str = ""
    long: str = ""

    def __str__(self) -> str:
        return clip(f"{self.word} {DASH} {self.detail}" if self.detail else self.word)

    def words(self) -> int:
        """Number of words of the short form."""
        return len(str(self).split())


def clip(text: str, most: int = MAX_WORDS) -> str:
    """``text`` cut to ``most`` words (an ellipsis says it was cut); newlines become spaces.

    Examples
    --------
    >>> from fl_design.app._brief import clip
    >>> clip("a b c d", 3)
    'a b …'
    """
    words = str(text).split()
    if len(words) <= most:
        return " ".join(words)
    return " ".join(words[:most - 1]) + " …"


def _n(x, digits: int = 3) -> str:
    return f"{x:.{digits}g}"


def run_brief(resp) -> Brief:
    """The short form of a run's verdict.

    Parameters
    ----------
    resp : fl_design.Response
        A run (its verdict, overshoot and band entry are told).

    Returns
    -------
    Brief
        The verdict word, its tone and one line of numbers.

    Examples
    --------
    >>> from fl_design.app._brief import run_brief
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 20.0))
    >>> str(run_brief(r))
    'converged — overshoot 0 %, in the band from 9.08 s'
    """
    m, status = resp.metrics, resp.status
    over = "" if not math.isfinite(m["overshoot"]) else f"overshoot {_n(m['overshoot'])} %"
    level = _LEVEL.get(status, "info")
    word = status.replace("_", " ")
    if status == "converged":
        when = (f"in the band from {_n(m['settling_time'])} s"
                if math.isfinite(m["settling_time"]) else f"offset {_n(m['steady_state_error'], 2)}")
        detail = ", ".join(x for x in (over, when) if x)
    elif status == "converging":
        t = m["time_to_tolerance"]
        when = (f"in the band at ~{_n(t)} s" + (" (beyond the run)" if t > resp.duration else "")
                if math.isfinite(t) else f"|e| {_n(m['tail_error'])} at the end")
        detail = ", ".join(x for x in (over, when) if x)
    elif status == "oscillating":
        detail = (f"swings {_n(m['oscillation_amplitude'])} peak-to-peak, period "
                  f"{_n(m['oscillation_period'])} s")
    elif status == "stalled":
        detail = f"offset {_n(m['steady_state_error'])}, band {_n(resp.tol)}"
        if not m.get("reached", 1):
            detail += ", never reaches r"
    elif status == "undecided":
        detail = (f"|e| {_n(m['tail_error'])} > band {_n(resp.tol)} at {_n(resp.duration)} s; "
                  "run longer")
    elif status == "diverged":
        detail = f"at t = {_n(m['divergence_time'])} s"
    else:
        detail = "the integrator gave up (not a verdict on the loop)"
    return Brief(word, level, detail, resp.verdict())


def window_brief(resp, window: float) -> str:
    """What a run of ``window`` seconds shows of the transient (the compared runs' column).

    Examples
    --------
    >>> from fl_design.app._brief import window_brief
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 20.0))
    >>> window_brief(r, 20.0)
    'in the band from 9.08 s'
    """
    m = resp.metrics
    if resp.status == "diverged":
        return f"diverged at {_n(m['divergence_time'])} s"
    reach = step_reach(resp)
    if reach < REACHES:
        return f"never reaches r (peak {100 * reach:.0f} % of the step)"
    if resp.status == "converged" and math.isfinite(m["settling_time"]):
        return f"in the band from {_n(m['settling_time'])} s"
    return f"|e| {_n(m['tail_error'])} at {_n(window)} s (band {_n(resp.tol)})"


def cert_brief(cert: dict | None) -> Brief:
    """The short form of the certificates: eps* certified and the gamma interval.

    Examples
    --------
    >>> from fl_design.app._brief import cert_brief
    >>> str(cert_brief(None)), str(cert_brief({"skipped": "no b-range"}))
    ('not run', 'not certified — no b-range')
    """
    if not cert:
        return Brief("not run", "info")
    if "eps" not in cert:
        return Brief("not certified", "warn", cert.get("skipped", "no b-range to certify"))
    g, e = cert["gamma"], cert["eps"]
    b = cert["box"]["b_bounds"] if cert.get("box") else list(e.b_bounds)
    if e.eps_star_certified is None:
        detail = f"no eps certified for the plant's class ({e.covers} b)"
    else:
        detail = (f"eps* {fmt(e.eps_star_certified)} s for its class ({e.covers} b), this eps "
                  f"{'inside' if e.certified else 'outside'}")
    detail += "; " + gamma_words(g)
    if cert.get("box"):
        detail += "; over the [uncertainty] box"
    return Brief("certified" if e.certified else "NOT certified",
                 "good" if e.certified else "bad", detail, cert_long(cert, b))


def gamma_words(g) -> str:
    """The admissible gamma interval and where the design's gamma lies in it (magnitudes for
    ``b < 0``, said so).

    Examples
    --------
    >>> from types import SimpleNamespace as S
    >>> from fl_design.app._brief import gamma_words
    >>> gamma_words(S(gamma=-0.00813, gamma_min=0.00818, gamma_max=0.0292, b_bounds=(-2, -1)))
    '|gamma| in (0.00818, 0.0292), this 0.00813 outside'
    >>> gamma_words(S(gamma=96.8, gamma_min=None, gamma_max=None, b_bounds=(1e-4, 3e-4)))
    'no gamma of the scan gives a stable loop at this eps'
    """
    neg = min(g.b_bounds) < 0
    mag, lo, hi = abs(g.gamma), g.gamma_min, g.gamma_max
    if lo is None or hi is None:  # the scan found no stable gamma at the design's eps
        return (f"no {'|gamma|' if neg else 'gamma'} of the scan gives a stable loop at this "
                "eps")
    return (f"{'|gamma|' if neg else 'gamma'} in ({fmt(lo, 'none', 3)}, {fmt(hi, 'none', 3)}), "
            f"this {fmt(mag, 'none', 3)} {'inside' if lo < mag < hi else 'outside'}")


def cert_long(cert: dict, b_bounds=None) -> str:
    """The certificates in full sentences: what is certified and which plants it covers.

    Examples
    --------
    >>> from fl_design.app._brief import cert_long
    >>> cert_long({"skipped": "no b-range"})
    'no b-range'
    """
    if "eps" not in cert:
        return cert.get("skipped", "no b-range to certify")
    g, e = cert["gamma"], cert["eps"]
    box = cert.get("box")
    family = ""
    if box:
        b_bounds = box["b_bounds"]
        ranges = ", ".join(f"{k} in [{lo:.4g}, {hi:.4g}]" for k, (lo, hi) in box["params"].items())
        family = (f" over the [uncertainty] box {ranges}" +
                  (f" (not {', '.join(box['not_covered'])}: a normal distribution has no box)"
                   if box["not_covered"] else ""))
    b = (f", b anywhere in [{b_bounds[0]:.3g}, {b_bounds[1]:.3g}]" if b_bounds is not None
         else "")
    cls = getattr(e, "class_description", "") or f"chain of integrators, sigma = b u{b}"
    unc = "; ".join(getattr(e, "uncovered", ()) or ())
    return (f"eps* = {fmt(e.eps_star_certified, 'none in range')} s, {gamma_words(g)}; this eps "
            f"{'certified' if e.certified else 'NOT certified'}: {e.reason}. Covers every "
            f"plant of the {cls}{family}" + (f"; not covered: {unc}" if unc else "")
            + ". This step on the nonlinear plant: "
            + cert.get("nonlinear_summary", "not analysed"))


def nonlinear_brief(cert: dict | None) -> Brief:
    """The short form of the nonlinear certificate (a region of the nonlinear plant).

    Examples
    --------
    >>> from fl_design.app._brief import nonlinear_brief
    >>> for cert in (None, {"nonlinear_summary": "not searched in --quick"}):
    ...     print(nonlinear_brief(cert))
    no certificate — the plant gives no region
    not searched — in --quick
    """
    text = (cert or {}).get("nonlinear_summary")
    if not text:
        return Brief("no certificate", "info", "the plant gives no region")
    if text.startswith("not searched"):
        return Brief("not searched", "info", text.removeprefix("not searched").strip())
    if text.startswith("certified"):
        where = text.split(";")[0].removeprefix("certified").strip()
        if len(where.split()) > 16:
            where = "in a part of the plant's region (see Certificates)"
        return Brief("certified", "good", where)
    return Brief("not certified", "warn", text.removeprefix("not certified").strip(" ()"))


def map_brief(smap, gamma: float) -> Brief:
    """The empirical eps* at the grid gamma nearest to ``gamma``, with the map's size.

    Examples
    --------
    >>> from fl_design.app._brief import map_brief
    >>> m = fl.StabilityMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[2], [-1]]), {},
    ...                     1e-3, 1.0, 0.1)
    >>> str(map_brief(m, 1.0))
    'eps* 0.1 s — at gamma 1, fails at 0.2 s, 2 x 1 noise-free runs of 1 s'
    """
    if smap is None:
        return Brief("not run", "info")
    g = float(smap.gamma[np.argmin(np.abs(np.log(smap.gamma / gamma)))])
    bracket = smap.eps_star(g)
    star = str(bracket)
    short = re.split(r" \(", star)[0]
    level = "warn" if "undecided" in star or short.startswith("<") else "good"
    lost = getattr(smap, "n_lost", 0)
    if lost:  # a partial map: never looks complete (its lost points read undecided)
        return Brief(f"eps* {short} s (PARTIAL map)", "bad",
                     f"at gamma {g:.3g}, {lost} of {np.size(smap.status)} runs lost",
                     f"{star}; {lost_line(smap)}")
    # the grid's last converging eps is a lower bound: say where the first failure is, so that a
    # certified eps* above it (between the two grid points) does not read as a contradiction
    fails = (f"fails at {bracket.upper:.3g} s, " if bracket.upper is not None
             and np.isfinite(bracket.upper) and "undecided" not in star else "")
    return Brief(f"eps* {short} s", level,
                 f"at gamma {g:.3g}, {fails}{smap.eps.size} x {smap.gamma.size} noise-free runs of "
                 f"{smap.duration:g} s", star)


def lost_line(result, what: str = "map") -> str:
    """One line saying how many runs of ``result`` were lost and which worker died ("" when
    none were: a complete result, or one that is not partial).

    A partial result (:class:`~fl_design.sim._partial.PartialStabilityMap` and its siblings)
    holds every finished run exactly as a complete one does; its lost runs are ``undecided``
    with NaN metrics. The line is what the report's summary, the console and stderr say.

    Parameters
    ----------
    result : object
        A map or ensemble; partial when it has ``n_lost`` > 0.
    what : str, optional
        What the result is called in the line.

    Examples
    --------
    >>> from fl_design.app._brief import lost_line
    >>> from fl_design.sim._partial import PartialStabilityMap
    >>> m = PartialStabilityMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[2], [3]]), {},
    ...                         1e-3, 1.0, 0.1, lost=np.array([[False], [True]]),
    ...                         lost_reason="worker lost: worker process 7 (exit code 3)")
    >>> lost_line(m)
    'map: 1 of 2 runs lost (worker process 7 (exit code 3) died); those points are undecided'
    >>> lost_line(None)
    ''
    """
    n = int(getattr(result, "n_lost", 0) or 0)
    if n == 0:
        return ""
    reason = str(getattr(result, "lost_reason", "worker lost"))
    who = reason.split(": ", 1)[1] if ": " in reason else "a worker"
    those = "those runs are" if what == "ensemble" else "those points are"
    return f"{what}: {n} of {np.size(result.status)} runs lost ({who} died); {those} undecided"


def code_brief(cg: dict | None) -> Brief:
    """The short form of the C stage: SIL verdict, operations, time per step, stack.

    Examples
    --------
    >>> from fl_design.app._brief import code_brief
    >>> str(code_brief({"skipped": "[codegen] enabled = false"}))
    'skipped — [codegen] enabled = false'
    """
    if not cg:
        return Brief("not run", "info")
    if "skipped" in cg:
        return Brief("skipped", "info", cg["skipped"])
    sil, cost = cg["sil"], cg["costs"].rows[0]
    ns = f", {cost.ns_per_step:.3g} ns/step" if math.isfinite(cost.ns_per_step) else ""
    tail = (f"{cost.flops} operations{ns}, {cost.stack_bytes} B stack; error "
            f"{sil.max_rel_error:.2g} (bound {sil.bound:g})")
    if sil.c_failed and sil.verdicts_agree:  # the design fails the scenario, not the C
        std = cg.get("sil_noise_std")
        under = f" under noise std {std:g}" if std else ""
        return Brief("SIL FAILED", "bad",
                     f"the loop is {sil.c_status}{under} in C as in Python: the design fails "
                     "this scenario (the C's fault handling then departs from Design.step); "
                     + tail)
    return Brief("SIL PASSED" if sil.passed else "SIL FAILED", "good" if sil.passed else "bad",
                 tail)


def design_brief(design) -> str:
    """A design in a few numbers: ``EHGO eps 0.05 s, gamma 0.0003, K (2, 4), T 0.001 s``.

    Examples
    --------
    >>> from fl_design.app._brief import design_brief
    >>> design_brief(fl.presets.paper_design())
    'EHGO eps 0.05 s, gamma 0.0003, K (2, 4), k_I 0.001, T 0.001 s'
    """
    est, ctl = design.estimator, design.controller
    what = f"EHGO eps {est.eps:g} s" if est.has_time_constant else f"LS({est.window})"
    gains = ", ".join(f"{k:g}" for k in ctl.gains)
    return clip(f"{what}, gamma {ctl.gamma:g}, K ({gains}), k_I {ctl.ki:g}, T {design.T:g} s")


def compare_brief(sim: dict | None) -> Brief:
    """The comparison at the largest noise level: each design's overshoot (or why none).

    Examples
    --------
    >>> from fl_design.app._brief import compare_brief
    >>> str(compare_brief(None))
    'not run'
    """
    if not sim:
        return Brief("not run", "info")
    std = max(sim["stds"])
    parts = []
    for name in sim["designs"]:
        r = sim["runs"][(name, std)]
        if r.status == "diverged":
            parts.append(f"{name} diverges")
        elif no_step(r):
            parts.append(f"{name}: no step")
        elif step_reach(r) < REACHES:
            parts.append(f"{name} never reaches r")
        else:
            parts.append(f"{name} {_n(r.overshoot)} %")
    return Brief("overshoot", "info", f"{'; '.join(parts)} (noise {std:.3g}, first "
                 f"{sim['compare_duration']:g} s)")


__all__ = ["DASH", "MAX_WORDS", "Brief", "cert_brief", "cert_long", "clip", "code_brief", "compare_brief",
           "design_brief", "lost_line", "map_brief", "nonlinear_brief", "run_brief", "window_brief"]
