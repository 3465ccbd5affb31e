"""A design proposed for a plant from expressions given without ``[design]``: :func:`fl.tune`.

One way to propose, the API's: :func:`fl_design.tune` with its default objective
(:data:`fl_design.tuning._tune.DEFAULT_OBJECTIVE`, the loop at the plant's own time scale, and
its documented fallbacks) and the configured step (``[scenario] reference``; not given: the
tuning's, the operating output plus 5 % of the output's range in the region). The tuning
says each choice with its number; those sentences (its warnings first) become the config's
notes, and the sweep and certificate ranges come from the tuning (T, the time scale and the
certified gamma interval) unless given; the compared noise levels, unless given, from the
step.

Examples
--------
>>> from fl_design.app import parse_config
>>> from fl_design.app._propose import propose_design
>>> cfg = parse_config('[plant]\\nstates = ["th", "om"]\\ninput = "u"\\n'
...     'rhs = ["om", "-9.81*sin(th) - 0.5*om + u"]\\noutput = "th"\\n'
...     'region = { th = [-3.0, 3.0], om = [-10.0, 10.0] }\\ninput_range = [-20.0, 20.0]\\n'
...     '[scenario]\\nreference = 0.1')
>>> new = propose_design(cfg)
>>> len(new.design.gains) == 2, "design proposed" in new.source
(True, True)
"""

from __future__ import annotations

from dataclasses import replace

from ._config import Config, ConfigError
from ._design_table import DesignTable


def propose_design(cfg: Config, plant=None) -> Config:
    """``cfg`` with the ``[design]`` of :func:`fl_design.tune` and its reasons in the notes.

    Parameters
    ----------
    cfg : Config
        A configuration whose plant is from expressions, without ``[design]``.
    plant : fl_design.Plant, optional
        Its plant (default :func:`fl_design.app.build_plant`).

    Returns
    -------
    Config
        With ``design`` filled, ``source`` saying ``(design proposed: ...)`` and one note per
        choice; the sweep and certify ranges are the tuning's unless given.

    Raises
    ------
    ConfigError
        No ``[scenario] reference``, or :class:`~fl_design.errors.NoDesignError` from the
        tuning (no region or input range, b changing sign, no converging candidate: the
        message says why).

    Examples
    --------
    See the module.
    """
    from ..errors import NoDesignError
    from ..tuning import tune
    from ._build import build_plant

    plant = plant if plant is not None else build_plant(cfg)
    r = None if cfg.scenario.reference is None else float(cfg.scenario.reference)
    try:  # fl.tune's default objective (the API's), with its documented fallbacks
        tuned = tune(plant, reference=r, progress=True)
    except NoDesignError as exc:
        raise ConfigError(f"{cfg.source}: [design] is missing and none can be proposed: "
                          f"{exc}; give [design] (gains, gamma, eps, T)") from exc
    return _config_with(cfg, tuned, [])


def _config_with(cfg: Config, tuned, extra: list) -> Config:
    est, ctrl = tuned.design.estimator, tuned.design.controller
    d = DesignTable(estimator="ehgo", eps=float(est.eps), T=float(est.T),
                    gains=tuple(float(k) for k in ctrl.gains), gamma=float(ctrl.gamma),
                    u_limits=tuple(float(v) for v in ctrl.u_range))
    ranges = tuned.ranges  # what the user gave is kept
    sweep = replace(cfg.sweep, eps=cfg.sweep.eps or tuple(ranges["sweep_eps"]),
                    gamma=cfg.sweep.gamma or tuple(ranges["sweep_gamma"]))
    certify = replace(cfg.certify, gamma=cfg.certify.gamma or tuple(ranges["certify_gamma"]),
                      eps_range=cfg.certify.eps_range or tuple(ranges["certify_eps"]))
    compare = replace(cfg.compare, eps_tradeoff=tuple(float(f"{est.eps * f:.3g}")
                                                      for f in (0.5, 1.0, 2.0, 4.0)))
    reasons = [f"WARNING: {w}" for w in tuned.warnings] + list(tuned.reasons) + \
        [f"not chosen: {t}" for t in tuned.tried] + extra
    scenario, compare, derived = _derived(cfg, tuned, compare)
    notes = tuple(cfg.notes) + tuple(derived) + tuple(f"[design] proposed: {r}" for r in reasons)
    gc = tuned.gamma_certificate
    why = (f"design proposed by fl.tune, no [design] given: loop at {tuned.time_scale:.3g} "
           f"rad/s, T = {est.T:g} s, gamma = {ctrl.gamma:.4g} (|gamma| in the admissible "
           f"[{_g(gc.gamma_min)}, {_g(gc.gamma_max)}]), eps = {est.eps:.4g} s "
           f"({'certified' if tuned.certified else 'NOT certified'} there), "
           f"check {tuned.status} with {tuned.overshoot:.3g} % overshoot; every reason in the "
           "notes (summary.json config.notes, stderr)")
    return replace(cfg, design=d, sweep=sweep, certify=certify, compare=compare,
                   scenario=scenario, source=f"{cfg.source} ({why})", notes=notes)


def _derived(cfg: Config, tuned, compare) -> tuple:
    """``(scenario, compare, notes)``: the reference and the compared noise, when not given,
    from the plant (the tuning's step) — never another plant's numbers."""
    notes, scenario = [], cfg.scenario
    if scenario.reference is None:
        scenario = replace(scenario, reference=float(tuned.reference))
        notes.append(f"[scenario] reference = {tuned.reference:.6g} (not given: the operating "
                     "output plus 5 % of the output's range in the region)")
    if not compare.noise_std:
        y_op = float(tuned.response.y[0]) if len(tuned.response.y) else 0.0
        step = abs(float(tuned.reference) - y_op) or 1.0
        stds = (float(f"{step / 300:.3g}"), float(f"{step * 0.105409:.3g}"))
        compare = replace(compare, noise_std=stds)
        notes.append(f"[compare] noise_std = {list(stds)} (not given: 1/300 and 0.105 of the "
                     f"step {step:.4g}, the paper's noise relative to its step)")
    notes += noise_room_notes(tuned, [scenario.noise_std, *compare.noise_std])
    return scenario, compare, notes


def noise_room_notes(tuned, stds) -> list:
    """A warning per sensor noise level whose rms in ``u`` (the tuning's noise gain times the
    level) exceeds a third of the input's room from its start to the nearer limit: ``u`` then
    saturates often and the noisy runs may diverge (``fl.tune`` for a plant does not see noise;
    ball and beam, rho = 4: noise gain 7.8e4, a noise of 1.67e-4 gives rms u 13 against a room
    of 20, and its compared runs diverged).

    Examples
    --------
    >>> from types import SimpleNamespace as NS
    >>> t = NS(noise_gain=7.793e4, response=NS(u=[0.0]),
    ...        design=NS(controller=NS(u_range=(-20.0, 20.0))))
    >>> noise_room_notes(t, [0.0, 1.67e-4])[0][:54]
    'sensor noise 0.000167 gives rms u 13 (noise gain 7.79e'
    >>> noise_room_notes(t, [1e-6])
    []
    """
    gain = float(getattr(tuned, "noise_gain", float("nan")))
    lo, hi = (float(v) for v in tuned.design.controller.u_range)
    u0 = float(tuned.response.u[0]) if len(tuned.response.u) else 0.5 * (lo + hi)
    room = min(hi - u0, u0 - lo)
    out = []
    for std in stds:
        rms = gain * float(std or 0.0)
        if std and room > 0 and rms > room / 3.0:
            out.append(f"sensor noise {std:.3g} gives rms u {rms:.3g} (noise gain "
                       f"{gain:.3g}), more than a third of the input's room {room:.3g} from "
                       f"u = {u0:.4g}: u saturates often and runs with this noise may diverge "
                       "(fl.tune does not see sensor noise): give [design] a larger eps (noise "
                       "~ 1/eps^rho) or a smaller gamma, or expect the noisy runs to fail")
    return out


def _g(x) -> str:
    return "-" if x is None else f"{abs(x):.4g}"


__all__ = ["noise_room_notes", "propose_design"]
