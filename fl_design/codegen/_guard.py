"""The firmware guard around the step: its defaults, the design's hash, and a Python model of it.

The C step (``templates/step.c.in``) wraps ``Design.step`` in checks a firmware needs. This
module holds what they start from and how they behave, in Python:

- :class:`GuardSettings` and :func:`guard_settings`: the defaults of the checks. The
  plausibility range of ``y`` is **on by default**: with a plant, the range of its output over
  its region (sampled at the box's corners and 4 096 points, then widened by half its span on
  each side: a sensor reading outside it is garbage); without one, ``|y| <= 1e9`` (catches
  ``1e30``-style garbage; give ``plant=`` for a real range). ``u_safe``, the input held while
  the sensor is lost or the parameter block is corrupted, is the controller's ``u0``, else the
  plant's equilibrium input, else 0, clamped to the input limits. ``lost_after``: 10 ms of
  rejections in a row, at least 3 samples. The rate check (``dy_max``) and the frozen-sensor
  check (``frozen_after``) are off by default: their thresholds need the sensor's noise and
  rate, which the design does not know (a quantized sensor at rest repeats its value).
- :func:`design_hash`: SHA-256 of the numbers that make the generated step (the header's
  ``PREFIX_DESIGN_HASH``).
- :class:`FirmwareModel`: the guard's logic sample by sample in Python around
  ``Design.step``'s own CasADi function, so that every fault case can be checked in C and in
  Python alike (``tests/codegen/test_faults.py``).

Examples
--------
>>> import fl_design as fl
>>> from fl_design import presets
>>> from fl_design.codegen._guard import guard_settings
>>> g = guard_settings(presets.maglev_design(), fl.plants.maglev())
>>> g.y_min < 0.004 < 0.008 < g.y_max, g.u_safe, g.lost_after
(True, 9.433322919684132, 10)
"""

from __future__ import annotations

import hashlib
import itertools
import math
from dataclasses import dataclass, replace

import numpy as np

#: the plausibility range of ``y`` when no plant is given: ``|y| <= Y_WIDE``
Y_WIDE = 1e9
#: samples between two checks of the parameter block against its checksum (the C default)
PARAM_CHECK_PERIOD = 100
#: fault bits (the header's ``PREFIX_FAULT_*``)
FAULT = {"nonfinite": 1, "range": 2, "rate": 4, "result": 8, "frozen": 16, "params": 32,
         "lost": 64}


@dataclass(frozen=True)
class GuardSettings:
    """Thresholds of the C step's checks (the parameter block's guard fields).

    Parameters
    ----------
    y_min, y_max : float
        Plausibility range of ``y`` (checked when ``y_min < y_max``).
    dy_max : float
        Largest accepted ``|y_k - y_(k-1)|`` (0: off).
    u_safe : float
        Input held while the sensor is lost or the parameter block is corrupted.
    lost_after : int
        Rejections in a row that declare the sensor lost (0: never).
    frozen_after : int
        The same ``y`` this many times in a row: a frozen sensor (0: off).
    u_op : float
        The input at the operating point (``main.c`` starts there).
    source : str
        Where the range came from (for the README).

    Examples
    --------
    >>> from fl_design.codegen._guard import GuardSettings
    >>> GuardSettings(-1.0, 1.0, 0.0, 0.0, 10, 0, 0.0, "given").y_max
    1.0
    """

    y_min: float
    y_max: float
    dy_max: float
    u_safe: float
    lost_after: int
    frozen_after: int
    u_op: float
    source: str


def _output_range(plant) -> tuple[float, float]:
    """The plant output's range over its region: the output state's own range, else the
    output over the corners and 4 096 points of the box (read without SymPy: a cached library
    plant's ranges come from its header, :meth:`Plant._state_ranges`)."""
    ranges, out = plant._state_ranges()
    if out is not None and ranges.get(out) is not None:
        lo, hi = ranges[out]
        return float(lo), float(hi)
    box = [tuple(r) if r is not None else (float(x), float(x))
           for r, x in zip(ranges.values(), plant.x_op)]
    lo, hi = np.array([b[0] for b in box]), np.array([b[1] for b in box])
    corners = np.array(list(itertools.product(*box)), dtype=float)
    inner = lo + (hi - lo) * np.random.default_rng(0).random((4096, lo.size))
    pts = np.vstack([corners, inner, plant.x_op[None, :]])
    h = plant.casadi().h.map(pts.shape[0])
    y = np.asarray(h(pts.T), dtype=float).ravel()
    y = y[np.isfinite(y)]
    return float(y.min()), float(y.max())


def guard_settings(design, plant=None) -> GuardSettings:
    """The default thresholds for ``design`` (and the plant's region, when given).

    Parameters
    ----------
    design : Design
        The design generated.
    plant : Plant, optional
        Its region gives the range of ``y``, its equilibrium the safe input.

    Returns
    -------
    GuardSettings

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._guard import guard_settings
    >>> g = guard_settings(presets.paper_design())
    >>> g.y_min, g.y_max, g.u_safe, g.dy_max, g.frozen_after
    (-1000000000.0, 1000000000.0, 0.0, 0.0, 0)
    """
    ctrl = design.controller
    u_op = float(ctrl.u0) if ctrl.u0 is not None else (
        float(plant.u_eq) if plant is not None else 0.0)
    if ctrl.u_range is not None:
        u_op = float(np.clip(u_op, *ctrl.u_range))
    if plant is not None:
        lo, hi = _output_range(plant)
        span = max(hi - lo, abs(hi) + abs(lo), 1e-12)
        y_min, y_max, source = lo - 0.5 * span, hi + 0.5 * span, (
            f"the output's range over the plant's region [{lo:.6g}, {hi:.6g}], widened by "
            "half its span on each side")
    else:
        y_min, y_max, source = -Y_WIDE, Y_WIDE, (
            f"|y| <= {Y_WIDE:g} (no plant given to generate_c: pass plant= for the region's "
            "range)")
    lost = max(3, math.ceil(0.01 / design.T))
    return GuardSettings(y_min, y_max, 0.0, u_op, lost, 0, u_op, source)


def design_hash(design, precision: str) -> str:
    """SHA-256 of the numbers the generated step is made of (hex, first 16 digits).

    Parameters
    ----------
    design : Design
        The design generated (after :func:`~fl_design.codegen.step_design`).
    precision : str
        The build's precision.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._guard import design_hash
    >>> d = presets.paper_design()
    >>> len(design_hash(d, "float")), design_hash(d, "float") != design_hash(d, "double")
    (16, True)
    """
    from ._graph import parameter_fields

    h = hashlib.sha256()
    for part in (type(design.estimator).__name__, repr(design), precision,
                 float(design.T).hex(),
                 *(float(v).hex() for v in np.ravel(design.estimator.parameter_vector())),
                 *(f"{f.name}={float(f.value).hex()}" for f in parameter_fields(design))):
        h.update(str(part).encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


class FirmwareModel:
    """The C step's guard, sample by sample, around ``Design.step`` (a model for the tests).

    Mirrors ``templates/step.c.in`` (the fault rules of the header's comment): rejection and
    resumption, the widening rate window, the frozen and lost sensor with ``u_safe``, the
    observer's restart after a non-finite result (or a non-finite input before its limits, e.g.
    a NaN gain, or a state entry that overflowed at the last sample), the parameter block's
    periodic check, the input limits the common path tests (the copies made when the block was
    last validated: a block corrupted since limits u by them until the check), manual mode.
    The arithmetic is the design's parametric step in double.

    Parameters
    ----------
    design : Design
        The generated design (``CPackage.step_design``).
    settings : GuardSettings
        The thresholds (the C defaults: :func:`guard_settings`).
    period : int, optional
        Samples between checks of the parameter block.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._guard import FirmwareModel, guard_settings
    >>> d = presets.paper_design()
    >>> m = FirmwareModel(d, guard_settings(d))
    >>> m.start(0.0, 0.0), m.step(float("nan"), 0.3), m.fault
    (0, 0.0, 1)
    """

    def __init__(self, design, settings: GuardSettings, *, period: int = PARAM_CHECK_PERIOD):
        from ._graph import parameter_fields, parametric_core, unsaturated_input

        self.design, self.settings, self.period = design, settings, int(period)
        self.fields = [f.name for f in parameter_fields(design)]
        self.p = {f.name: f.value for f in parameter_fields(design)}
        self.core = parametric_core(design)
        self.unsaturated = unsaturated_input(self.core)
        self.c0, self.c1 = _start_map(design)
        self.m = int(design.estimator.state_size)
        self.x = np.asarray(design.initial_state(), dtype=float)
        self.p_sum = self._sum()
        self._derive()
        self.countdown, self.bad_block, self.restart_due = self.period, False, False
        self.y_last, self.last_known = 0.0, False
        self.n_consecutive = self.n_same = self.fault = self.faults = 0
        self.sensor_lost, self.manual, self.u_manual = False, False, settings.u_safe

    def _sum(self):
        return hash((tuple(self.p.values()), self.settings))

    def _derive(self) -> None:
        # the C's derived copy of the input limits (PREFIX_derive: their order keys in float), set with
        # the block and refreshed at each good checksum check; the common path tests u before
        # its limits against it
        self.u_lim = (self.p.get("u_min", -math.inf), self.p.get("u_max", math.inf))

    def corrupt(self, **values) -> None:
        """Change parameters behind the setter (a RAM fault): the checksum is not updated."""
        self.p.update(values)

    def _restart(self, y0: float, u0: float, keep_z: bool) -> None:
        lo, hi = self.p["u_min"], self.p["u_max"]
        z = self.x[self.m + 1] if keep_z and math.isfinite(self.x[self.m + 1]) else 0.0
        self.x = np.concatenate([self.c0 + self.c1 * y0, [min(max(u0, lo), hi), z]])
        self.y_last, self.last_known = y0, True
        self.n_consecutive = self.n_same = self.fault = 0
        self.sensor_lost = self.restart_due = False

    def start(self, y0: float, u0: float) -> int:
        """``PREFIX_start``: 0, or the C's ``BAD_*`` code (9: checksum, 1: non-finite)."""
        if self._sum() != self.p_sum:
            return 9
        if not (math.isfinite(y0) and math.isfinite(u0)):
            return 1
        self._restart(y0, u0, keep_z=False)
        self.bad_block, self.u_manual = False, self.x[self.m]
        return 0

    def _reject(self, fault: int) -> float:
        s = self.settings
        self.n_consecutive += 1
        self.fault = fault
        if fault == FAULT["frozen"] or 0 < s.lost_after <= self.n_consecutive:
            self.sensor_lost = True
            self.fault |= FAULT["lost"]
            self.x[self.m] = s.u_safe
        if not math.isfinite(self.x[self.m]):
            self.x[self.m] = s.u_safe
        self.faults |= self.fault
        return float(self.x[self.m])

    def step(self, y: float, r: float) -> float:
        """``PREFIX_step``: the input to apply."""
        s = self.settings
        self.countdown -= 1
        if self.countdown == 0:
            self.countdown = self.period
            self.bad_block |= self._sum() != self.p_sum
            if not self.bad_block:
                self._derive()
        self.fault = 0
        if self.bad_block:
            self.fault = FAULT["params"]
            self.faults |= self.fault
            self.x[self.m] = s.u_safe
            return s.u_safe
        if not (math.isfinite(y) and math.isfinite(r)):
            return self._reject(FAULT["nonfinite"])
        if s.y_min < s.y_max and not s.y_min <= y <= s.y_max:
            return self._reject(FAULT["range"])
        if s.frozen_after > 0 and self.last_known:
            self.n_same = self.n_same + 1 if y == self.y_last else 0
            if self.n_same >= s.frozen_after:
                return self._reject(FAULT["frozen"])
        if self.sensor_lost or self.restart_due:
            u = self.x[self.m]
            ok = math.isfinite(u) and self.p["u_min"] <= u <= self.p["u_max"]
            self._restart(y, u if ok else s.u_safe, keep_z=True)
        lim = s.dy_max * (self.n_consecutive + 1)
        if s.dy_max > 0 and self.last_known and abs(y - self.y_last) > lim:
            return self._reject(FAULT["rate"])
        p = [self.p[f] for f in self.fields]
        # the C's common path: u before its limits strictly within the derived limits is u
        # (PREFIX_core_fast); else the law with the block's own limits (PREFIX_core)
        v = float(self.unsaturated(self.x, y, r, p))
        lo, hi = self.u_lim
        if lo < v < hi and "u_min" in self.p:
            p = [lo if f == "u_min" else hi if f == "u_max" else self.p[f] for f in self.fields]
        x_next, u, _ = (np.asarray(v, dtype=float).ravel() for v in self.core(self.x, y, r, p))
        # the C's test (._finite): the state (an overflowed result stored by the last sample
        # among it), y, r and the input before its limits; then u is finite
        if not (np.all(np.isfinite(self.x)) and math.isfinite(v)):
            self.restart_due = True
            return self._reject(FAULT["result"])
        z_before = self.x[self.m + 1]
        self.x = x_next
        self.n_consecutive, self.y_last, self.last_known = 0, y, True
        if self.manual:
            self.x[self.m], self.x[self.m + 1] = self.u_manual, z_before
            return float(self.u_manual)
        return float(u[0])

    def disengage(self) -> None:
        """``PREFIX_disengage``."""
        self.manual, self.u_manual = True, float(self.x[self.m])

    def manual_input(self, u: float) -> None:
        """``PREFIX_manual_input`` (clamped to the input limits)."""
        self.u_manual = min(max(u, self.p["u_min"]), self.p["u_max"])

    def engage(self) -> None:
        """``PREFIX_engage``."""
        self.manual = False

    def with_settings(self, **changes) -> FirmwareModel:
        """A fresh model with some thresholds changed (``PREFIX_set_params`` then ``init``)."""
        return FirmwareModel(self.design, replace(self.settings, **changes), period=self.period)


def _start_map(design):
    from ._graph import start_map

    return start_map(design)


__all__ = ["FAULT", "PARAM_CHECK_PERIOD", "Y_WIDE", "FirmwareModel", "GuardSettings",
           "design_hash", "guard_settings"]
