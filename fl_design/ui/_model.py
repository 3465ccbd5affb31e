"""The tuner's model: a plant, a base design and a scenario; one redraw from the page's numbers.

:class:`Tuner` is built once from a validated :class:`fl_design.app.Config`; its
:meth:`Tuner.redraw` takes the page's controls (a plain dict of numbers, checked here: a bad
value is a :class:`~fl_design.errors.ParameterError` naming it and what is valid) and returns
what the page draws: the step response (``y`` and ``r``, ``u``, ``sigma`` and ``sigmahat``,
decimated to at most :data:`MAX_POINTS` points with each bucket's minimum and maximum kept, so
peaks and noise bands survive), the verdict with overshoot and settling time, and the noise
gain. The computation is the library's (:func:`fl_design.simulate`, the compiled kernel;
:func:`fl_design.analysis.noise_gain`): the page only binds controls to it.

Examples
--------
>>> from fl_design.app._cli import ui_setup
>>> from fl_design.ui._model import Tuner
>>> tuner = Tuner(ui_setup())
>>> view = tuner.redraw(tuner.defaults() | {"duration": 2.0})
>>> view["verdict"]["status"] in ("converged", "converging", "undecided", "oscillating")
True
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from .. import _validate as V
from ..errors import FlDesignError, ParameterError
from ._loops import LoopCache

#: Most points per trace sent to the page (min and max of each bucket; the verdict is computed on
#: every sample).
MAX_POINTS = 2000
#: Longest run the page may ask for (seconds of simulated time).
MAX_DURATION = 600.0
#: Default run length when the config's is "adaptive" (s).
DEFAULT_DURATION = 20.0
#: The page's controls and what each is (the page builds its sliders from :meth:`Tuner.controls`).
CONTROL_NAMES = ("gamma", "eps", "gains", "T", "reference", "noise_std", "u_min", "u_max",
                 "duration")


def decimate(t: np.ndarray, columns: dict, max_points: int = MAX_POINTS) -> tuple:
    """Keep each bucket's minimum and maximum (in time order) of every column.

    Parameters
    ----------
    t : numpy.ndarray
        ``(N,)`` sample times.
    columns : dict
        Name -> ``(N,)`` array.
    max_points : int, optional
        At most this many points are kept: ``(max_points - 2) // (2 * len(columns))``
        buckets, at most two points per bucket and column (fewer where the columns' extremes
        coincide), and the first and last sample.

    Returns
    -------
    (numpy.ndarray, dict)
        The kept times and, per column, the kept values: one set of indices for every column,
        the union of all columns' bucket extremes (and the first and last sample), sorted.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.ui._model import decimate
    >>> t = np.arange(10.0)
    >>> tt, cols = decimate(t, {"y": np.array([0, 5, 1, 1, 1, 1, 1, -3, 1, 1.0])}, max_points=4)
    >>> float(cols["y"].max()), float(cols["y"].min())
    (5.0, -3.0)
    """
    n = t.size
    if n <= max_points:
        return t, columns
    buckets = max(1, (max_points - 2) // (2 * max(1, len(columns))))
    size = math.ceil(n / buckets)
    base = np.arange(buckets) * size
    keep = [np.array([0, n - 1])]
    for x in columns.values():
        pad = np.full(buckets * size, np.nan)
        pad[:n] = x
        block = pad.reshape(buckets, size)
        ok = ~np.all(np.isnan(block), axis=1)
        block = np.where(ok[:, None], block, 0.0)
        keep += [(base + np.nanargmin(block, axis=1))[ok], (base + np.nanargmax(block, axis=1))[ok]]
    idx = np.unique(np.concatenate(keep))
    idx = idx[idx < n]
    return t[idx], {k: np.asarray(v)[idx] for k, v in columns.items()}


def _finite_list(x) -> list:
    """A strict-JSON list: NaN and infinities as None."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    if ok.all():
        return x.tolist()
    return [v if f else None for v, f in zip(x.tolist(), ok.tolist())]


def _number(name: str, value) -> float:
    if isinstance(value, bool) or not V.is_real_number(value) or not math.isfinite(value):
        raise ParameterError(f"{name} must be a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class TunerSetup:
    """What the tuner starts from, made by the command line (the tuner never imports ``app``).

    Parameters
    ----------
    config : fl_design.app.Config
        The validated configuration (read by attribute: ``design``, ``scenario``, ``sweep``,
        ``certify``, ``codegen``, ``classifier``, ``plant``, ``source``).
    plant : fl_design.Plant
        Its plant.
    design : fl_design.Design
        Its design (an EHGO under the dynamic controller).
    render : callable
        ``render(config, header) -> str``: a config as commented TOML (the "save" button).
    library : mapping
        Library plant key -> ``(factory name in fl.plants, keyword arguments)`` (the snippet).
    plant_class : fl_design.PlantClass, optional
        The class mode (``--class``): ``plant`` is one member of it (simulated) and the
        certificates are computed for the whole class.

    Examples
    --------
    >>> from fl_design.app._cli import ui_setup
    >>> ui_setup().plant.name
    'trms_yaw'
    """

    config: object
    plant: object
    design: object
    render: Callable
    library: Mapping
    plant_class: object = None


class Tuner:
    """The tuner's state: a config's plant, design and scenario (read once).

    Parameters
    ----------
    setup : TunerSetup
        The configuration with its plant and design
        (:func:`fl_design.app._cli.ui_setup` makes one).
    compile_aside : bool, optional
        New gains, T or limits run first in the interpreter while their C kernel compiles in
        a child process (:class:`fl_design.ui._loops.LoopCache`); the server turns it on.

    Raises
    ------
    ParameterError
        The config has no design, a least-squares design (the tuner moves eps), or no
        reference.

    Examples
    --------
    >>> from fl_design.app._cli import ui_setup
    >>> from fl_design.ui import Tuner
    >>> Tuner(ui_setup()).defaults()["gamma"]
    0.0003
    """

    def __init__(self, setup: TunerSetup, *, compile_aside: bool = False) -> None:
        config = setup.config
        if config.design is None or setup.design is None:
            raise ParameterError(f"{config.source}: the tuner needs a [design] (gains, gamma, eps, "
                                 "T): add one, or run `fl-design run` to have one proposed")
        if config.design.estimator != "ehgo":
            raise ParameterError(f"{config.source}: the tuner tunes an EHGO design; [design] "
                                 f"estimator = {config.design.estimator!r}: use estimator = "
                                 '"ehgo"')
        if config.scenario.reference is None:
            raise ParameterError(f"{config.source}: the tuner needs [scenario] reference (the "
                                 "output's step target)")
        self.setup = setup
        self.config, self.plant, self.design = config, setup.plant, setup.design
        self.classifier = config.classifier
        self.rho = self.plant.relative_degree()
        self.plant_class = setup.plant_class
        self.b_bounds = self._b_bounds() if self.plant_class is None else \
            tuple(float(x) for x in self.plant_class.b)
        #: what the certificates cover: the class, or the plant's own class (read by the
        #: certificates from the plant: its b, slopes and b's rate over its region)
        self.cert_target = self.plant_class or (self.plant if self.b_bounds is not None
                                                else None)
        self.loops = LoopCache(compile_aside=compile_aside)

    def _b_bounds(self):
        p = self.plant
        if p.region is None or p.input_range is None:
            return None
        lo, hi = p.b_bounds(allow_sign_change=True)
        return (float(lo), float(hi)) if lo * hi > 0 else None

    # --- the controls -----------------------------------------------------------------------
    def defaults(self) -> dict:
        """The config's numbers as the page's controls.

        Returns
        -------
        dict
            ``gamma, eps, gains, T, reference, noise_std, u_min, u_max, duration`` (``u_min``,
            ``u_max`` None without input limits).

        Examples
        --------
        >>> from fl_design.app._cli import ui_setup
        >>> from fl_design.ui._model import Tuner
        >>> Tuner(ui_setup()).defaults()["gains"]
        [2.0, 4.0]
        """
        d, s = self.config.design, self.config.scenario
        lim = d.u_limits or (None, None)
        dur = s.duration if isinstance(s.duration, (int, float)) else DEFAULT_DURATION
        return {"gamma": d.gamma, "eps": d.eps, "gains": list(d.gains), "T": d.T,
                "reference": s.reference, "noise_std": s.noise_std, "u_min": lim[0],
                "u_max": lim[1], "duration": float(min(dur, MAX_DURATION))}

    def controls(self) -> list:
        """The sliders: name, label, scale (log/linear), range and value of each.

        Returns
        -------
        list of dict
            One per slider, in the page's order.

        Examples
        --------
        >>> from fl_design.app._cli import ui_setup
        >>> from fl_design.ui._model import Tuner
        >>> [c["name"] for c in Tuner(ui_setup()).controls()][:3]
        ['gamma', 'eps', 'k1']
        """
        v, cfg = self.defaults(), self.config
        g_lo, g_hi = sorted(abs(x) for x in (cfg.sweep.gamma or (v["gamma"] / 30,
                                                                  v["gamma"] * 30)))
        e_lo, e_hi = cfg.sweep.eps or (v["eps"] / 30, v["eps"] * 30)
        sign = math.copysign(1.0, v["gamma"])
        out = [{"name": "gamma", "label": "gamma" + (" (negative, as b)" if sign < 0 else ""),
                "scale": "log", "min": g_lo, "max": g_hi, "value": abs(v["gamma"]),
                "sign": sign},
               {"name": "eps", "label": "eps (s)", "scale": "log", "min": e_lo, "max": e_hi,
                "value": v["eps"]}]
        out += [{"name": f"k{i + 1}", "label": f"k{i + 1}", "scale": "log", "min": k / 20,
                 "max": k * 20, "value": k} for i, k in enumerate(v["gains"])]
        out.append({"name": "T", "label": "T (s), recompiles", "scale": "log",
                    "min": v["T"] / 10, "max": v["T"] * 10, "value": v["T"]})
        lo, hi = self._reference_range(v["reference"])
        out.append({"name": "reference", "label": "reference", "scale": "linear", "min": lo,
                    "max": hi, "value": v["reference"]})
        std = v["noise_std"]
        out.append({"name": "noise_std", "label": "noise std (left end: none)", "scale": "log0",
                    "min": 1e-5, "max": 1e-1, "value": std})
        if v["u_min"] is not None:
            span = max(abs(v["u_min"]), abs(v["u_max"]))
            out += [{"name": "u_min", "label": "u min", "scale": "linear", "min": -4 * span,
                     "max": v["u_max"], "value": v["u_min"]},
                    {"name": "u_max", "label": "u max", "scale": "linear", "min": v["u_min"],
                     "max": 4 * span, "value": v["u_max"]}]
        out.append({"name": "duration", "label": "run length (s)", "scale": "linear",
                    "min": 1.0, "max": max(60.0, v["duration"]), "value": v["duration"]})
        return out

    def _reference_range(self, r: float) -> tuple:
        ranges, y = self.plant._state_ranges()
        if y is not None and ranges.get(y) is not None:
            return tuple(float(x) for x in ranges[y])
        return (r - 2 * abs(r) - 1.0, r + 2 * abs(r) + 1.0)

    def check(self, values: dict) -> dict:
        """The page's numbers, checked: known names, finite numbers, the right count of gains.

        Parameters
        ----------
        values : dict
            Any of :data:`CONTROL_NAMES` (missing ones: the defaults).

        Returns
        -------
        dict
            All controls.

        Raises
        ------
        ParameterError
            An unknown name, a value that is not a finite number, a wrong number of gains, a
            run length outside (0, :data:`MAX_DURATION`].

        Examples
        --------
        >>> from fl_design.app._cli import ui_setup
        >>> from fl_design.ui._model import Tuner
        >>> Tuner(ui_setup()).check({"eps": "x"})
        Traceback (most recent call last):
        ...
        fl_design.errors.ParameterError: eps must be a finite number, got 'x'
        """
        if not isinstance(values, dict):
            raise ParameterError(f"the controls must be a JSON object, got {type(values).__name__}")
        unknown = sorted(set(values) - set(CONTROL_NAMES))
        if unknown:
            raise ParameterError(f"unknown controls {unknown}; valid: {', '.join(CONTROL_NAMES)}")
        out = self.defaults() | values
        for k in ("gamma", "eps", "T", "reference", "noise_std", "duration"):
            out[k] = _number(k, out[k])
        gains = out["gains"]
        if not isinstance(gains, list) or len(gains) != self.rho:
            raise ParameterError(f"gains must be a list of {self.rho} numbers (relative degree "
                                 f"{self.rho}), got {gains!r}")
        out["gains"] = [_number(f"k{i + 1}", g) for i, g in enumerate(gains)]
        if (out["u_min"] is None) != (out["u_max"] is None):
            raise ParameterError("give both u_min and u_max, or neither")
        if out["u_min"] is not None:
            out["u_min"], out["u_max"] = _number("u_min", out["u_min"]), _number("u_max",
                                                                                 out["u_max"])
        if not 0 < out["duration"] <= MAX_DURATION:
            raise ParameterError(f"duration must be in (0, {MAX_DURATION:g}] s, got "
                                 f"{out['duration']!r}")
        if out["noise_std"] < 0:
            raise ParameterError(f"noise_std must be >= 0, got {out['noise_std']!r}")
        return out

    # --- objects from the controls --------------------------------------------------------------
    def design_for(self, v: dict):
        """The :class:`fl_design.Design` of checked controls ``v`` (the library validates).

        Examples
        --------
        >>> from fl_design.app._cli import ui_setup
        >>> from fl_design.ui._model import Tuner
        >>> t = Tuner(ui_setup())
        >>> t.design_for(t.defaults() | {"gamma": 1e-3}).controller.gamma
        0.001
        """
        from ..design import Design

        limits = None if v["u_min"] is None else (v["u_min"], v["u_max"])
        est = self.design.estimator.replace(eps=v["eps"], T=v["T"])
        ctrl = self.design.controller.replace(gains=tuple(v["gains"]), gamma=v["gamma"],
                                              u_limits=limits)
        return Design(estimator=est, controller=ctrl)

    def scenario_for(self, v: dict):
        """The :class:`fl_design.Scenario` of checked controls ``v``."""
        table = dataclasses.replace(self.config.scenario, reference=v["reference"])
        return table.build(duration=v["duration"], noise_std=v["noise_std"])

    def config_for(self, v: dict):
        """The config with the controls' numbers in ``[design]`` and ``[scenario]``."""
        d = self.config.design
        design = dataclasses.replace(d, eps=v["eps"], gamma=v["gamma"], T=v["T"],
                                     gains=tuple(v["gains"]),
                                     u_limits=() if v["u_min"] is None else
                                     (v["u_min"], v["u_max"]))
        scenario = dataclasses.replace(self.config.scenario, reference=v["reference"],
                                       duration=v["duration"], noise_std=v["noise_std"])
        return dataclasses.replace(self.config, design=design, scenario=scenario)

    # --- the fast path ----------------------------------------------------------------------
    def warm_up(self) -> dict:
        """The defaults' redraw with their kernel compiled here (before the page asks).

        Returns
        -------
        dict
            As :meth:`redraw`.
        """
        aside, self.loops.compile_aside = self.loops.compile_aside, False
        try:
            return self.redraw({})
        finally:
            self.loops.compile_aside = aside

    def redraw(self, values: dict) -> dict:
        """Simulate the controls' loop: traces, verdict, noise gain, the time it took.

        Parameters
        ----------
        values : dict
            The page's controls (:meth:`check`).

        Returns
        -------
        dict
            Strict JSON: ``t``, ``y``, ``r``, ``u``, ``sigma``, ``sigmahat`` (decimated),
            ``verdict`` (status, overshoot %, settling time s, steady-state error, the
            response's verdict sentence), ``noise_gain`` (u rms per unit noise rms, or its
            reason), ``compute_ms`` (wall clock) and ``cpu_ms`` (this thread's CPU time: what
            the redraw costs apart from other processes' load). A value the library refuses is
            ``{"error": message}``.

        Raises
        ------
        ParameterError
            What :meth:`check` refuses.
        """
        start, cpu = time.perf_counter(), time.thread_time()
        v = self.check(values)
        try:
            design = self.design_for(v)
            resp = self.loops.simulate(self.plant, design, self.scenario_for(v),
                                       classifier=self.classifier)
        except FlDesignError as err:
            return {"error": str(err), "values": v}
        t, cols = decimate(np.asarray(resp.t), {
            "y": resp.y, "r": resp.r, "u": resp.u, "sigma": resp.sigma,
            "sigmahat": resp.sigmahat})
        out = {k: _finite_list(x) for k, x in cols.items()} | {"t": _finite_list(t)}
        out["verdict"] = {"status": resp.status, "overshoot": _num(resp.overshoot),
                          "settling_time": _num(resp.settling_time),
                          "steady_state_error": _num(resp.steady_state_error),
                          "text": resp.verdict(), "duration": float(resp.duration)}
        out["kernel"] = "compiled" if self.loops.last_compiled else \
            "interpreted (the C kernel of these gains, T or limits is compiling)"
        out["noise_gain"] = self._noise_gain(design, v)
        out["values"] = v
        out["compute_ms"] = 1e3 * (time.perf_counter() - start)
        out["cpu_ms"] = 1e3 * (time.thread_time() - cpu)
        return out

    def _noise_gain(self, design, v) -> dict:
        try:
            g = self.loops.noise_gain(self.plant, design, r=v["reference"])
        except FlDesignError as err:
            return {"value": None, "text": f"no noise gain: {err}"}
        if not math.isfinite(g):
            return {"value": None, "text": "noise gain: infinite (the linearized loop is not "
                    "stable)"}
        return {"value": g, "text": f"noise gain: u rms = {g:.3g} x the measurement noise rms "
                f"(linearized loop at r = {v['reference']:g})"}


def _num(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


__all__ = ["CONTROL_NAMES", "MAX_POINTS", "Tuner", "TunerSetup", "decimate"]
