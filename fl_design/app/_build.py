"""From a validated :class:`~fl_design.app.Config` to library objects: plant, design, runs.

Examples
--------
>>> from fl_design.app import build_design, build_plant, load_config
>>> cfg = load_config(None)
>>> build_plant(cfg).name, build_design(cfg).estimator.eps
('trms_yaw', 0.05)
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import ParameterError
from ._config import Config, ConfigError


def _library(key: str, motor_lag: bool):
    from .. import plants
    from ._plant_table import LIBRARY

    factory, kwargs = LIBRARY[key]
    return getattr(plants, factory)(**({"motor_lag": True} if motor_lag else {}) | kwargs)


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


def build_plant(cfg: Config):
    """The plant of ``[plant]``: a library plant, or one built from SymPy strings.

    Parameters
    ----------
    cfg : Config
        A validated configuration; its ``[plant]`` table is read (expressions through the
        grammar, never evaluated).

    Returns
    -------
    fl_design.Plant
        The library plant (with its motor lag if asked), or one from the expressions.

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
    if not p.expression:
        return _library(p.library, p.motor_lag)  # known by its recipe: no SymPy when cached
    import sympy as sp  # here only: a cached library plant's run never imports it

    states = [sp.Symbol(str(s), real=True) for s in p.states]
    u = sp.Symbol(p.input, real=True)
    names = {s.name: s for s in states} | {u.name: u}
    names |= {k: sp.Symbol(k, real=True) for k in p.params or {}}
    rhs = [_parse(f"rhs[{i}]", e, names) for i, e in enumerate(p.rhs)]
    output = _parse("output", p.output, names)
    kwargs = {"params": dict(p.params) if p.params else None, "name": p.name or "plant"}
    if p.region is not None:
        kwargs["region"] = dict(p.region)
    if p.input_range is not None:
        kwargs["input_range"] = p.input_range
    if p.operating_point is not None:
        kwargs["operating_point"] = dict(p.operating_point)
    from ..errors import FlDesignError

    try:
        return Plant.from_ode(states, u, rhs, output, **kwargs)
    except (FlDesignError, ValueError) as err:  # the API's whole message, after the table
        raise ConfigError(f"[plant] {err}") from None


def build_design(cfg: Config, *, eps: float | None = None, window: int | None = None,
                 rho: int | None = None):
    """The design of ``[design]`` (EHGO or least squares) under its dynamic controller.

    Parameters
    ----------
    cfg : Config
        A validated configuration with a ``[design]`` table.
    eps : float, optional
        Override the observer's eps.
    window : int, optional
        Build the least-squares baseline with this window instead.
    rho : int, optional
        Relative degree (default: the number of gains).

    Returns
    -------
    fl_design.Design
        Under the configured controller, with the configured or the overridden estimator.

    Examples
    --------
    >>> from fl_design.app import build_design, load_config
    >>> build_design(load_config(None), window=9).estimator.window
    9
    """
    if cfg.design is None:
        raise ConfigError(f"{cfg.source}: [design] is missing: a plant from expressions has no "
                          "bench design; add [design] with gains, gamma, eps and T (see "
                          "`fl-design init --from-ode`)")
    try:
        return cfg.design.build(rho=rho, eps=eps, window=window)
    except ParameterError as err:  # a length that does not fit the plant's relative degree
        raise ConfigError(f"{cfg.source}: [design] {err}") from None


def build_scenario(cfg: Config, *, duration: float | None = None, noise_std: float | None = None,
                   seed: int | None = None):
    """The scenario of ``[scenario]`` (a step to ``reference``, its disturbances), optionally
    changed.

    Parameters
    ----------
    cfg : Config
        A validated configuration with ``[scenario] reference``.
    duration, noise_std : float, optional
        Overrides (``duration="adaptive"``: a scenario without a duration, the run chooses
        it from the loop).
    seed : int, optional
        Noise seed override.

    Returns
    -------
    fl_design.Scenario
        A new scenario (the overrides change nothing in ``cfg``).

    Examples
    --------
    >>> from fl_design.app import build_scenario, load_config
    >>> build_scenario(load_config(None), duration=2.0).duration
    2.0
    """
    if cfg.scenario.reference is None:
        raise ConfigError(f"{cfg.source}: [scenario] reference is missing: give the output's "
                          "step target (absolute, in the plant's units)")
    return cfg.scenario.build(duration=duration, noise_std=noise_std, seed=seed)


def build_classifier(cfg: Config):
    """The classifier of ``[classifier]``: the table is read as a :class:`fl_design.Classifier`
    itself (tolerance, windows), validated when the config was.

    Parameters
    ----------
    cfg : Config
        A validated configuration (the defaults without ``[classifier]``).

    Returns
    -------
    fl_design.Classifier

    Examples
    --------
    >>> from fl_design.app import build_classifier, load_config
    >>> build_classifier(load_config(None)).tolerance
    0.02
    """
    return cfg.classifier


def check_fit(cfg: Config, plant) -> tuple:
    """Check ``cfg`` against its plant before any work; return the warnings (strings).

    Refuses (:class:`ConfigError`, one message with the numbers) a missing ``[design]`` for a
    plant from expressions (naming its relative degree, b-range and input range, what to add)
    and a reference outside the plant's region; warns when the operating point was not given
    and when the reference is the output at the operating point (no step to run).

    Parameters
    ----------
    cfg : Config
        A validated configuration (``[design]``, ``[scenario]`` and ``[plant]`` are checked).
    plant : fl_design.Plant
        Its plant (:func:`build_plant`).

    Returns
    -------
    tuple of str
        Warnings (the config's own notes first).

    Raises
    ------
    ConfigError
        As above.

    Examples
    --------
    >>> from fl_design.app import build_plant, load_config
    >>> from fl_design.app._build import check_fit
    >>> cfg = load_config(None)
    >>> check_fit(cfg, build_plant(cfg))
    ()
    """
    from ..design import gains_from_poles

    notes = list(cfg.notes)
    if cfg.design is None:
        rho = plant.relative_degree()
        has_b = plant.region is not None and plant.input_range is not None
        b = plant.b_bounds(allow_sign_change=True) if has_b else None
        sign = "" if b is None else (" (> 0, as b)" if b[0] > 0 else " (< 0, as b)"
                                     if b[1] < 0 else "")
        bound = "" if b is None or b[0] * b[1] <= 0 else \
            f"; |gamma| < 1/max|b| = {1 / max(abs(b[0]), abs(b[1])):.3g}"
        raise ConfigError(
            f"{cfg.source}: [design] is missing for the plant {plant.name!r} (relative degree "
            f"{rho}" + ("" if b is None else f", b in [{b[0]:.4g}, {b[1]:.4g}]")
            + ("" if plant.input_range is None else
               f", input range [{plant.input_range[0]:g}, {plant.input_range[1]:g}]")
            + f"): add [design] with gains ({rho} numbers, e.g. "
            f"{list(gains_from_poles([-1.0] * rho))}), gamma{sign}{bound}, eps and T (s), "
            "and u_limits if the input is limited; `fl-design init --from-ode` shows one")
    if cfg.scenario.reference is None:
        raise ConfigError(f"{cfg.source}: [scenario] reference is missing: give the output's "
                          f"step target (absolute, in the plant's units; the output "
                          f"{plant.output} is {_y_op(plant):g} at the operating point)")
    _check_reference(cfg, plant)
    _check_gamma_sign(cfg, plant)
    r, y_op = cfg.scenario.reference, _y_op(plant)
    if isinstance(r, (int, float)) and abs(r - y_op) <= 1e-9 * max(1.0, abs(y_op)):
        notes.append(f"[scenario] reference = {r:g} is the output's value at the operating "
                     f"point: every run starts at its target and shows no step (no "
                     f"overshoot; the map's verdicts are about staying there); give a "
                     f"reference away from {y_op:g}")
    if cfg.plant.expression and cfg.plant.operating_point is None:
        notes.append(f"[plant] operating_point not given: the origin, with u_eq = "
                     f"{plant.u_eq:g} (give e.g. operating_point = {{ "
                     f"{plant.states[0].name} = ... }})")
    return tuple(notes)


def _y_op(plant) -> float:
    return float(plant.casadi().h(plant.x_op))


def _check_gamma_sign(cfg: Config, plant) -> None:
    if not any(plant._state_ranges()[0].values()) or plant.input_range is None:
        return  # no region (read without SymPy) or no input range: b is not bounded
    lo, hi = plant.b_bounds(allow_sign_change=True)
    g = cfg.design.gamma
    if lo * hi > 0 and g * lo < 0:
        word = "< 0" if lo < 0 else "> 0"
        raise ConfigError(f"{cfg.source}: [design] gamma = {g:g} but b in [{lo:.4g}, {hi:.4g}] "
                          f"on the plant's region: gamma takes the sign of b; give gamma {word} "
                          f"(e.g. gamma = {-g:g})")


def _check_reference(cfg: Config, plant) -> None:
    ranges, y = plant._state_ranges()  # no SymPy for a cached library plant
    if y is not None and ranges[y] is not None:
        lo, hi = ranges[y]
        r = cfg.scenario.reference
        if not lo <= r <= hi:
            raise ConfigError(f"{cfg.source}: [scenario] reference = {r:g} is outside the "
                              f"plant's region {y} in [{lo:g}, {hi:g}]: give a reference "
                              "inside it (or widen [plant] region)")


def design_name(design) -> str:
    """The short name of a design in tables and file names: ``EHGO eps=0.05`` or ``LS(9)``.

    Examples
    --------
    >>> from fl_design.app._build import design_name
    >>> design_name(fl.presets.paper_design()), design_name(fl.presets.least_squares_design(9))
    ('EHGO eps=0.05', 'LS(9)')
    """
    est = design.estimator
    return f"EHGO eps={est.eps:g}" if est.has_time_constant else f"LS({est.window})"


@dataclass(frozen=True)
class Setup:
    """The config turned into objects once: every stage is a function of these.

    Parameters
    ----------
    config : Config
        The validated configuration.
    plant : fl_design.Plant
        ``[plant]``.
    design : fl_design.Design
        ``[design]``.
    scenario : fl_design.Scenario
        ``[scenario]`` as given (stages change its length and noise with ``replace``).
    classifier : fl_design.Classifier
        ``[classifier]``.
    compared : dict
        Design name -> design of the comparison (this design first, then the least-squares
        baselines of ``[compare] windows`` when this design has an eps).

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._build import build_setup
    >>> list(build_setup(load_config(None)).compared)
    ['EHGO eps=0.05', 'LS(9)', 'LS(26)']
    """

    config: Config
    plant: object
    design: object
    scenario: object
    classifier: object
    compared: dict = field(default_factory=dict)

    def run_scenario(self, *, duration=None, noise_std: float | None = None,
                     seed: int | None = None):
        """The configured scenario with another length, noise level or seed (a copy).

        Parameters
        ----------
        duration : float or str, optional
            Seconds, or ``"adaptive"`` (the run chooses); default as configured.
        noise_std : float, optional
            Sensor noise; default as configured.
        seed : int, optional
            Noise seed; default as configured.

        Returns
        -------
        fl_design.Scenario
            The setup's own scenario when nothing changes, else a changed copy.

        Examples
        --------
        >>> from fl_design.app import load_config
        >>> from fl_design.app._build import build_setup
        >>> build_setup(load_config(None)).run_scenario(duration=2.0, noise_std=0.1).noise.std
        0.1
        """
        from ..sim import Noise

        if self.scenario is None:  # no reference: build_scenario says what to add
            return build_scenario(self.config, duration=duration, noise_std=noise_std,
                                  seed=seed)
        changes = {}
        if duration is not None:
            changes["duration"] = None if duration == "adaptive" else float(duration)
        if noise_std is not None or seed is not None:
            old = self.scenario.noise
            changes["noise"] = Noise(old.std if noise_std is None else noise_std,
                                     seed=old.seed if seed is None else seed)
        return self.scenario.replace(**changes) if changes else self.scenario


def build_setup(cfg: Config) -> Setup:
    """Plant, design, scenario, classifier and the compared designs of ``cfg``, built once.

    Parameters
    ----------
    cfg : Config
        A validated configuration (every table is read).

    Returns
    -------
    Setup
        Its scenario None when ``[scenario] reference`` is missing (what needs it says so).

    Raises
    ------
    DesignMismatchError
        ``[design] gains`` has not as many entries as the plant's relative degree.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._build import build_setup
    >>> s = build_setup(load_config(None))
    >>> s.plant.name, s.design.controller.gamma, s.scenario.reference
    ('trms_yaw', 0.0003, 0.3)
    """
    from ..errors import DesignMismatchError

    plant = build_plant(cfg)
    rho = plant.relative_degree()
    if cfg.design is not None and len(cfg.design.gains) != rho:
        raise DesignMismatchError(
            f"[design] gains has {len(cfg.design.gains)} entries but the plant "
            f"{plant.name!r} has relative degree {rho}: give {rho} gains (and "
            f"{rho + 1} coeffs)")
    design = build_design(cfg, rho=rho)
    compared = {design_name(design): design}
    if design.estimator.has_time_constant:
        compared |= {f"LS({w})": build_design(cfg, window=int(w), rho=rho)
                     for w in cfg.compare.windows}
    scenario = build_scenario(cfg) if cfg.scenario.reference is not None else None
    return Setup(cfg, plant, design, scenario, build_classifier(cfg), compared)


__all__ = ["Setup", "build_classifier", "build_design", "build_plant", "build_scenario",
           "build_setup", "check_fit", "design_name"]
