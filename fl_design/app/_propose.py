"""A design proposed for a plant from expressions given without ``[design]``.

From the plant alone: its relative degree, its b-range (region and input range), and its time
scale (the largest eigenvalue modulus of the linearization at the operating point, at least
1 rad/s, at most the rate at which a fifth of the input's room moves the step through
``y^(rho) = b u``). The closed loop decays at that rate (all its poles there,
:func:`fl_design.gains_from_poles`); ``T`` samples it 100 times faster (1-2-5 rounded);
``|gamma|`` makes the disturbance estimate ``5x`` faster than the loop (``gamma max|b| T``
per sample, the sign of ``b``); ``eps`` is half the linearized ``eps*`` (at most ``0.2 / decay``, at least ``2 T``);
the input is limited to the input range. A simulation of the configured step checks it;
otherwise ``|gamma|`` is tried 3x smaller and larger. Each choice is said with its number.

Examples
--------
>>> from fl_design.app import parse_config
>>> from fl_design.app._propose import propose_design
>>> cfg = parse_config('[plant]\\nstates = ["th", "om"]\\ninput = "u"\\n'
...     'rhs = ["om", "-9.81*sin(th) - 0.5*om + u"]\\noutput = "th"\\n'
...     'region = { th = [-3.0, 3.0], om = [-10.0, 10.0] }\\ninput_range = [-20.0, 20.0]\\n'
...     '[scenario]\\nreference = 0.1')
>>> new = propose_design(cfg)
>>> len(new.design.gains), "design proposed" in new.source
(2, True)
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ._config import Config, ConfigError
from ._design_table import DesignTable


def _nice(x: float) -> float:
    """Round down to 1, 2 or 5 times a power of ten."""
    e = math.floor(math.log10(x))
    m = x / 10 ** e
    return float(f"{(5 if m >= 5 else 2 if m >= 2 else 1) * 10 ** e:.3g}")


def propose_design(cfg: Config, plant=None) -> Config:
    """``cfg`` with a proposed ``[design]`` (see the module) and the reasons in its notes.

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
        choice; the sweep and certify ranges follow the proposed design unless given.

    Raises
    ------
    ConfigError
        No region or input range (no b-range to size gamma), or no candidate converged in the
        check simulation (the message says what was tried).

    Examples
    --------
    See the module.
    """
    from ..analysis import linearized_eps_star
    from ..design import EHGO, Design, DynamicController, gains_from_poles
    from ..sim import Scenario, simulate
    from ._build import build_plant
    from ._template import default_ranges

    plant = plant if plant is not None else build_plant(cfg)
    rho = plant.relative_degree()
    if plant.region is None or plant.input_range is None:
        raise ConfigError(f"{cfg.source}: [design] is missing and cannot be proposed: the plant "
                          "declares no region and input range (no b-range to size gamma); add "
                          "[plant] region and input_range, or [design]")
    lo, hi = plant.b_bounds(allow_sign_change=True)
    if lo * hi <= 0:
        raise ConfigError(f"{cfg.source}: [design] cannot be proposed: b changes sign on the "
                          f"region (b in [{lo:.4g}, {hi:.4g}]); shrink [plant] region")
    if cfg.scenario.reference is None:
        raise ConfigError(f"{cfg.source}: [scenario] reference is missing: give the output's "
                          "step target (absolute, in the plant's units)")
    sign, bmax = math.copysign(1.0, lo), max(abs(lo), abs(hi))
    A = np.asarray(plant.linearization()[0], dtype=float)
    speed = float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0
    # what the actuator allows: y^(rho) ~ b u moves the step in about (step / (b du))^(1/rho),
    # with a fifth of the input's room from u_eq to the nearer limit
    step = abs(cfg.scenario.reference - float(plant.casadi().h(plant.x_op)))
    room = min(plant.u_eq - plant.input_range[0], plant.input_range[1] - plant.u_eq)
    reach = (0.2 * min(abs(lo), abs(hi)) * room / step) ** (1.0 / rho) \
        if step > 0 and room > 0 else math.inf
    decay = max(0.01, min(max(1.0, speed), reach))
    T = min(0.1, max(1e-4, _nice(1.0 / (100.0 * decay))))
    gains = gains_from_poles([-decay] * rho)  # the loop at the plant's own time scale
    gains_why = f"closed loop (s + {decay:.3g})^{rho}"
    u_limits = tuple(plant.input_range)
    tried = []
    for factor in (1.0, 1 / 3, 3.0, 0.1, 10.0):
        gamma = sign * 5.0 * decay * T / bmax * factor
        ctrl = DynamicController(gains, gamma, u_limits=u_limits)
        probe = Design(estimator=EHGO(rho=rho, eps=max(2 * T, 1 / decay), T=T), controller=ctrl)
        star = linearized_eps_star(plant, probe, eps_range=(T, 10.0 / decay))
        if star.value is None and not star.above_range:
            tried.append(f"gamma {gamma:.3g}: no stable eps in [{T:g}, {10 / decay:g}] s")
            continue
        eps = max(2.0 * T, min(float(star.lower) / 2.0, 0.2 / decay))
        design = probe.replace(eps=eps)
        resp = simulate(plant, design, Scenario(cfg.scenario.reference))
        if resp.status in ("converged", "converging"):
            reasons = [
                (f"time scale {decay:.3g} rad/s (largest |eigenvalue| of the linearization "
                 f"{speed:.3g}, at least 1; at most {reach:.3g}, what a fifth of the input's "
                 f"room {room:.3g} moves the step {step:.3g} at)"),
                f"T = {T:g} s (100 samples per time constant, 1-2-5 rounded)",
                f"gains {tuple(round(k, 6) for k in gains)} ({gains_why})",
                (f"gamma = {gamma:.3g} (sign of b in [{lo:.4g}, {hi:.4g}]; disturbance "
                 f"estimate {5 * factor:.3g}x the loop's rate; paper bound |gamma| < "
                 f"{1 / bmax:.3g})"),
                (f"eps = {eps:.3g} s (half the linearized eps* {star}, at most 0.2/decay, "
                 "at least 2 T)"),
                f"u_limits = {u_limits} (the input range)",
                (f"checked: a step to {cfg.scenario.reference:g} is {resp.status} "
                 f"({resp.verdict()})")]
            return _config_with(cfg, design, reasons + tried, default_ranges(eps, T, gamma))
        tried.append(f"gamma {gamma:.3g}, eps {eps:.3g}: {resp.status}")
    raise ConfigError(f"{cfg.source}: [design] is missing and no proposal converged (tried "
                      + "; ".join(tried) + "): give [design] (`fl-design init --from-ode` "
                      "shows one)")


def _config_with(cfg: Config, design, reasons: list, ranges: dict) -> Config:
    est, ctrl = design.estimator, design.controller
    d = DesignTable(estimator="ehgo", eps=float(est.eps), T=float(est.T),
                    gains=tuple(float(k) for k in ctrl.gains), gamma=float(ctrl.gamma),
                    u_limits=tuple(float(v) for v in ctrl.u_limits))
    sweep = replace(cfg.sweep, eps=cfg.sweep.eps or ranges["sweep_eps"],
                    gamma=cfg.sweep.gamma or ranges["sweep_gamma"])
    certify = replace(cfg.certify, gamma=cfg.certify.gamma or ranges["certify_gamma"],
                      eps_range=cfg.certify.eps_range or sweep.eps)
    compare = replace(cfg.compare, eps_tradeoff=tuple(float(f"{est.eps * f:.3g}")
                                                      for f in (0.5, 1.0, 2.0, 4.0)))
    notes = tuple(cfg.notes) + tuple(f"[design] proposed: {r}" for r in reasons)
    return replace(cfg, design=d, sweep=sweep, certify=certify, compare=compare,
                   source=f"{cfg.source} (design proposed: no [design] given; see the notes)",
                   notes=notes)


__all__ = ["propose_design"]
