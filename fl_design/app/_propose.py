"""A design proposed for a plant from expressions given without ``[design]``: :func:`fl.tune`.

One way to propose: :func:`fl_design.tune` with the configured step (``[scenario]
reference``), objective ``"fastest"`` with the loop at the plant's own time scale (one
candidate: the report's simulation should settle within its run); when that loop has no
design, loops at half and a quarter of it (a lagging actuator), the faster settling one. The tuning says each choice
with its number (time scale, T, gains, gamma inside the certified interval, eps the largest
with a certified margin, the check simulation and sweep, the noise gain); those sentences
become the config's notes, and the sweep and certificate ranges come from the tuning (T, the
time scale and the certified gamma interval) unless given.

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
    if cfg.scenario.reference is None:
        raise ConfigError(f"{cfg.source}: [scenario] reference is missing: give the output's "
                          "step target (absolute, in the plant's units)")
    r, first_why = float(cfg.scenario.reference), []
    try:
        tuned = tune(plant, reference=r, objective="fastest", decays=(1.0,))
    except NoDesignError as first:
        first_why = [f"not chosen: the loop at the plant's time scale: {first}"]
        try:  # slower loops: what a lagging actuator may still follow
            tuned = tune(plant, reference=r, objective="fastest", decays=(0.5, 0.25))
        except NoDesignError as exc:
            raise ConfigError(f"{cfg.source}: [design] is missing and none can be proposed: "
                              f"{first}; then {exc}; give [design] (`fl-design init --from-ode` "
                              "shows one)") from exc
    return _config_with(cfg, tuned, first_why)


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
    reasons = list(tuned.reasons) + [f"not chosen: {t}" for t in tuned.tried] + extra
    notes = tuple(cfg.notes) + tuple(f"[design] proposed: {r}" for r in reasons)
    gc = tuned.gamma_certificate
    star = "-" if tuned.eps_star_certified is None else f"{tuned.eps_star_certified:.4g} s"
    why = (f"design proposed by fl.tune, no [design] given: loop at {tuned.time_scale:.3g} "
           f"rad/s, T = {est.T:g} s, gamma = {ctrl.gamma:.4g} (|gamma| in the admissible "
           f"[{_g(gc.gamma_min)}, {_g(gc.gamma_max)}]), eps = {est.eps:.4g} s "
           f"({'certified' if tuned.certified else 'NOT certified'}, certified eps* {star}), "
           f"check {tuned.status} with {tuned.overshoot:.3g} % overshoot; every reason in the "
           "notes (summary.json config.notes, stderr)")
    return replace(cfg, design=d, sweep=sweep, certify=certify, compare=compare,
                   source=f"{cfg.source} ({why})", notes=notes)


def _g(x) -> str:
    return "-" if x is None else f"{abs(x):.4g}"


__all__ = ["propose_design"]
