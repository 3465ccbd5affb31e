"""Numbers and results in words: the helpers every report and console module shares.

Pure functions of result objects (no job, no figures): a number or its reason, the paper's
gamma bound, eps* brackets, overshoot, a design's one-line label.

Examples
--------
>>> from fl_design.app._text import fmt
>>> fmt(float("nan"), "no boundary"), fmt(0.123456)
('no boundary', '0.1235')
"""

from __future__ import annotations

import math

import numpy as np


def paper_gamma_bound(b_bounds) -> tuple[float, str]:
    """The paper's gain condition ``gamma < 1/b_max`` for a ``b`` range of either sign.

    ``gamma`` takes the sign of ``b``, so the bound is on ``|gamma|``: ``1 / max|b|``.

    Parameters
    ----------
    b_bounds : (float, float)
        ``b`` over the plant's region.

    Returns
    -------
    (float, str)
        The bound on ``|gamma|`` (NaN when ``b`` changes sign) and the condition in words.

    Examples
    --------
    >>> from fl_design.app._text import paper_gamma_bound
    >>> paper_gamma_bound((3.6, 6.8))[1], paper_gamma_bound((-174.6, -18.19))[1]
    ('gamma < 1/b_max = 0.1471', '|gamma| < 1/max|b| = 0.005727 (gamma < 0, as b)')
    """
    lo, hi = (float(v) for v in b_bounds)
    if lo > 0:
        return 1.0 / hi, f"gamma < 1/b_max = {1.0 / hi:.4g}"
    if hi < 0:
        return 1.0 / abs(lo), f"|gamma| < 1/max|b| = {1.0 / abs(lo):.4g} (gamma < 0, as b)"
    return math.nan, "b changes sign over the region: the paper's gamma bound does not apply"


def fmt(value, missing: str = "-", digits: int = 4) -> str:
    """A number with ``digits`` significant digits, or ``missing`` (with its reason) for None/NaN.

    Parameters
    ----------
    value : float or None
        The number.
    missing : str, optional
        What to print instead of None or NaN (say why).
    digits : int, optional
        Significant digits.

    Examples
    --------
    >>> from fl_design.app._text import fmt
    >>> fmt(None, "not certified")
    'not certified'
    """
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return missing
    return f"{value:.{digits}g}"


def linearized_text(star) -> str:
    """A linearized eps* bracket in words, saying when the boundary lies outside the range.

    Parameters
    ----------
    star : fl_design.sim.EpsStar
        The result of :func:`fl_design.linearized_eps_star`.

    Examples
    --------
    >>> from fl_design.app._text import linearized_text
    >>> linearized_text(fl.EpsStar(1.0, float("inf")))
    '> 1 s (stable on the whole scanned range: no boundary found up to 1 s)'
    >>> linearized_text(fl.EpsStar(0.0417, 0.0418))
    '0.0417 s (unstable at 0.0418 s)'
    """
    if star.above_range:
        return (f"> {star.lower:g} s (stable on the whole scanned range: no boundary found up "
                f"to {star.lower:g} s)")
    if star.below_range:
        return f"< {star.upper:g} s (unstable already at the smallest eps scanned)"
    lower, upper = str(star).removesuffix(")").split(" (fails at ")  # the digits it needs
    return f"{lower} s (unstable at {upper} s)"


def bounded_up_to(smap, gamma: float) -> str:
    """Largest grid eps below which every run at ``gamma`` stays bounded (not diverged).

    Parameters
    ----------
    smap : fl_design.StabilityMap
        A sweep; only its statuses are read.
    gamma : float
        One of the map's gammas.

    Returns
    -------
    str
        ``"> eps_max"`` when no run diverged, ``"< eps_min"`` when the first did.

    Examples
    --------
    >>> from fl_design.app._text import bounded_up_to
    >>> m = fl.StabilityMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[0], [-1]]), {},
    ...                     1e-3, 1.0, 0.1)
    >>> bounded_up_to(m, 1.0)
    '0.1 (diverges at 0.2)'
    """
    j = int(np.argmin(np.abs(np.log(smap.gamma / gamma))))
    ok = np.asarray(smap.status)[:, j] >= 0
    if ok.all():
        return f"> {smap.eps[-1]:g}"
    first = int(np.argmin(ok))
    if first == 0:
        return f"< {smap.eps[0]:g}"
    return f"{smap.eps[first - 1]:g} (diverges at {smap.eps[first]:g})"


#: A run whose output's largest excursion stays below this fraction of the step never reaches
#: the reference: its "overshoot" is not one.
REACHES = 0.9


def run_length_note(result, chosen_on: str) -> str:
    """``Run length chosen <chosen_on>: <why>.`` for a result whose run length was adaptive;
    empty when it was given.

    Parameters
    ----------
    result : fl_design.StabilityMap or fl_design.Ensemble or fl_design.RobustMap
        Anything with a ``duration_reason``.
    chosen_on : str
        Where the rule looked (``"from the loop"``, ``"on the nominal plant"``).

    Returns
    -------
    str

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from fl_design.app._text import run_length_note
    >>> run_length_note(SimpleNamespace(duration_reason="8 x tau"), "from the loop")
    'Run length chosen from the loop: 8 x tau.'
    >>> run_length_note(SimpleNamespace(duration_reason="given"), "from the loop")
    ''
    """
    why = result.duration_reason
    return "" if why == "given" else f"Run length chosen {chosen_on}: {why}."


def step_reach(resp) -> float:
    """The output's largest excursion from its start, as a fraction of the step.

    Examples
    --------
    >>> from fl_design.app._text import step_reach
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 20.0))
    >>> step_reach(r) >= REACHES
    True
    """
    return float(np.nanmax(np.abs(resp.y - resp.y0))) / max(abs(resp.step), 1e-300)


def no_step(resp) -> bool:
    """True when the run has no step: its reference is where its output starts (its
    overshoot is NaN, its step reach meaningless).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from fl_design.app._text import no_step
    >>> no_step(SimpleNamespace(step=0.0, y0=0.15)), no_step(SimpleNamespace(step=0.05, y0=0.15))
    (True, False)
    """
    return not abs(resp.step) > 1e-12 * max(1.0, abs(resp.y0))


def overshoot_text(resp) -> str:
    """Overshoot in %, or why it is not one (diverged; does not track).

    Parameters
    ----------
    resp : fl_design.Response
        A run (its status, output and overshoot are read).

    Returns
    -------
    str
        A number (``"12.3"``, no ``%``), ``"n/a (diverged)"``, or a phrase starting
        ``"none: "`` (the output never reaches the reference, or there is no step: the
        reference is where the output starts).

    Examples
    --------
    >>> from fl_design.app._text import overshoot_text
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 20.0))
    >>> overshoot_text(r)
    '0'
    """
    if resp.status == "diverged":
        return "n/a (diverged)"
    if no_step(resp):
        return "none: no step (the reference is the output's start)"
    reach = step_reach(resp)
    if reach < REACHES:
        return f"none: never reaches the reference (peak {100 * reach:.0f} % of the step)"
    return f"{resp.overshoot:.3g}"


def design_label(design) -> str:
    """One line naming a design's numbers (used in every figure title).

    Parameters
    ----------
    design : fl_design.Design
        The design.

    Examples
    --------
    >>> from fl_design.app._text import design_label
    >>> design_label(fl.presets.least_squares_design(9))[:5]
    'LS(9)'
    """
    est, ctrl = design.estimator, design.controller
    head = f"EHGO eps = {est.eps:g} s" if est.has_time_constant else f"LS({est.window})"
    gains = ", ".join(f"{k:g}" for k in ctrl.gains)
    return (f"{head}, gamma = {ctrl.gamma:g}, K = ({gains}), k_I = {ctrl.ki:g}, "
            f"T = {design.T:g} s")


__all__ = ["REACHES", "bounded_up_to", "design_label", "fmt", "linearized_text", "no_step", "overshoot_text",
           "paper_gamma_bound", "run_length_note", "step_reach"]
