"""From a validated :class:`~fl_design.app.Config` to library objects: plant, design, runs.

Examples
--------
>>> from fl_design.app import build_design, build_plant, load_config
>>> cfg = load_config(None)
>>> build_plant(cfg).name, build_design(cfg).estimator.eps
('trms_yaw', 0.05)
"""

from __future__ import annotations

import sympy as sp

from ._config import Config, ConfigError


def _library(key: str, motor_lag: bool):
    from .. import plants

    factories = {"trms": lambda: plants.trms_yaw(motor_lag=motor_lag),
                 "trms-lag": lambda: plants.trms_yaw(motor_lag=True),
                 "pendulum": plants.pendulum, "flexible-joint": plants.flexible_joint,
                 "cart-pendulum": plants.cart_pendulum, "maglev": plants.maglev}
    return factories[key]()


def _parse(key: str, text, names: dict):
    """One expression string of ``[plant]``, through the grammar (never evaluated as Python)."""
    from ..errors import ExpressionError
    from ..symbolic._grammar import parse_expression

    if not isinstance(text, str):
        raise ConfigError(f"[plant] {key} must be a string expression, got {text!r}")
    try:
        return parse_expression(text, names, what=f"[plant] {key}")
    except ExpressionError as err:
        raise ConfigError(str(err)) from None


def _pairs(key: str, table: dict) -> dict:
    out = {}
    for name, value in table.items():
        if not (isinstance(value, list) and len(value) == 2):
            raise ConfigError(f"[plant] {key}.{name} must be [lo, hi], got {value!r}")
        out[name] = tuple(float(v) for v in value)
    return out


def build_plant(cfg: Config):
    """The plant of ``[plant]``: a library plant, or one built from SymPy strings.

    Parameters
    ----------
    cfg : Config
        A validated configuration.

    Returns
    -------
    fl_design.Plant

    Examples
    --------
    >>> from fl_design.app import build_plant, parse_config
    >>> cfg = parse_config('[plant]\\nstates = ["th", "om"]\\ninput = "u"\\n'
    ...                    'rhs = ["om", "-k*sin(th) + u"]\\noutput = "th"\\nparams = {k = 9.81}')
    >>> build_plant(cfg).relative_degree()
    2
    """
    from ..symbolic import Plant

    p = cfg.plant
    if "library" in p:
        return _library(p["library"], bool(p.get("motor_lag", False)))
    states = [sp.Symbol(str(s), real=True) for s in p["states"]]
    u = sp.Symbol(p["input"], real=True)
    names = {s.name: s for s in states} | {u.name: u}
    names |= {k: sp.Symbol(k, real=True) for k in p.get("params", {})}
    rhs = [_parse(f"rhs[{i}]", e, names) for i, e in enumerate(p["rhs"])]
    output = _parse("output", p["output"], names)
    kwargs = {"params": p.get("params") or None, "name": p.get("name", "plant")}
    if "region" in p:
        kwargs["region"] = _pairs("region", p["region"])
    if "input_range" in p:
        kwargs["input_range"] = tuple(float(v) for v in p["input_range"])
    if "operating_point" in p:
        kwargs["operating_point"] = {k: float(v) for k, v in p["operating_point"].items()}
    return Plant.from_ode(states, u, rhs, output, **kwargs)


def _limits(value) -> tuple | None:
    if not value:
        return None
    out = []
    for v in value:
        if isinstance(v, str):
            if v.lower() != "none":
                raise ConfigError(f"[design] estimate_limits entries are numbers or \"none\", "
                                  f"got {v!r}")
            out.append(None)
        else:
            out.append(float(v))
    return tuple(out)


def build_design(cfg: Config, *, eps: float | None = None, window: int | None = None,
                 rho: int | None = None):
    """The design of ``[design]`` (EHGO or least squares) under its dynamic controller.

    Parameters
    ----------
    cfg : Config
        A validated configuration.
    eps : float, optional
        Override the observer's eps.
    window : int, optional
        Build the least-squares baseline with this window instead.
    rho : int, optional
        Relative degree (default: the number of gains).

    Returns
    -------
    fl_design.Design

    Examples
    --------
    >>> from fl_design.app import build_design, load_config
    >>> build_design(load_config(None), window=9).estimator.window
    9
    """
    from ..design import EHGO, Design, DynamicController, LeastSquaresEstimator

    d = cfg.design
    gains = tuple(float(k) for k in d["gains"])
    rho = rho or len(gains)
    u_limits = tuple(float(v) for v in d["u_limits"]) if d.get("u_limits") else None
    ctrl = DynamicController(gains, float(d["gamma"]), ki=float(d["ki"]), u_limits=u_limits,
                             estimate_limits=_limits(d.get("estimate_limits")))
    if window is None and d["estimator"] == "least_squares":
        window = int(d.get("window", 9))
    if window is not None:
        est = LeastSquaresEstimator(rho=rho, T=float(d["T"]), window=int(window))
    else:
        coeffs = tuple(float(c) for c in d["coeffs"]) if d.get("coeffs") else None
        est = EHGO(rho=rho, eps=float(eps if eps is not None else d["eps"]), T=float(d["T"]),
                   coeffs=coeffs)
    return Design(estimator=est, controller=ctrl)


def build_scenario(cfg: Config, *, duration: float | None = None, noise_std: float | None = None,
                   seed: int | None = None):
    """The scenario of ``[scenario]`` (a step to ``reference``), optionally changed.

    Parameters
    ----------
    cfg : Config
        A validated configuration.
    duration, noise_std : float, optional
        Overrides (``duration="adaptive"``: a scenario without a duration, the run chooses
        it from the loop).
    seed : int, optional
        Noise seed override.

    Returns
    -------
    fl_design.Scenario

    Examples
    --------
    >>> from fl_design.app import build_scenario, load_config
    >>> build_scenario(load_config(None), duration=2.0).duration
    2.0
    """
    from ..sim import Noise, Scenario

    s = cfg.scenario
    std = float(s["noise_std"] if noise_std is None else noise_std)
    length = s["duration"] if duration is None else duration
    return Scenario(float(s["reference"]), None if length == "adaptive" else float(length),
                    noise=Noise(std, seed=int(s["seed"] if seed is None else seed)))


def build_classifier(cfg: Config):
    """The classifier of ``[scenario]`` (its relative ``tolerance``).

    Parameters
    ----------
    cfg : Config
        A validated configuration.

    Returns
    -------
    fl_design.Classifier

    Examples
    --------
    >>> from fl_design.app import build_classifier, load_config
    >>> build_classifier(load_config(None)).tolerance
    0.02
    """
    from ..sim import Classifier

    return Classifier(tolerance=float(cfg.scenario["tolerance"]))


__all__ = ["build_classifier", "build_design", "build_plant", "build_scenario"]
