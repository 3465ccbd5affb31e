"""A prepared run: the closed loop, its samples and constants, shared by simulate and sweep.

:func:`prepare_run` turns the option objects (:class:`~fl_design.Scenario`,
:class:`~fl_design.RK4`, :class:`~fl_design.Classifier`) into a :class:`RunSetup` at the
design's sampling time; :meth:`RunSetup.initial_accumulator` lays out one accumulator per run
(:func:`fl_design.sim.accumulator_layout`) with the initial values of
:data:`fl_design.sim._metrics.ACCUMULATORS`.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim._run import prepare_run
>>> d = fl.presets.pendulum_design()
>>> run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.1, 1.0))
>>> run.N, run.k_tail, run.step
(1000, 800, 0.1)
>>> run.initial_accumulator(d.parameter_vector()).shape  # one column per parameter vector
(106, 1)
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .. import _validate as V
from .._limits import check_memory
from ..errors import DimensionError, ParameterError, RelativeDegreeError
from ._duration import resolve_duration
from ._metrics import accumulators_for, initial_values, requested_metrics
from ._options import RK4, Classifier, Scenario, option
from .kernel._loop import ClosedLoop, resolve_substeps


@dataclass(frozen=True)
class RunSetup:
    """Validated inputs of one run (or of every run of a sweep): samples and constants.

    Built by :func:`prepare_run`. ``r`` and ``noise`` are the per-sample inputs ``d_k``; the
    constants go into every accumulator.

    Parameters
    ----------
    loop : ClosedLoop
        Plant, design and integrator.
    scenario : Scenario
        The scenario, its duration resolved (as given, or chosen from the loop).
    classifier : Classifier
        The classifier as given.
    N : int
        Samples.
    r, noise : numpy.ndarray
        ``(N,)`` reference and measurement noise (the output disturbance included).
    x0 : numpy.ndarray
        Initial plant state.
    s0 : numpy.ndarray
        Initial design state: the estimator at rest at the first measurement (or at the
        scenario's ``initial_estimate``), ``u0`` (the plant's ``u_eq`` unless the controller
        sets it), ``z = 0``.
    y0, step, tol, q : float
        Initial output, ``r[-1] - y0``, absolute tolerance, quantization step (0: none).
    k_tail : int
        First sample of the tail window.
    bound : numpy.ndarray
        Divergence bound per state.
    region : numpy.ndarray
        ``(2, n)`` lower and upper bounds of the plant's declared region (``-inf``/``inf``
        where none is declared).
    duration_reason : str, optional
        ``"given"``, or how the adaptive run length was chosen (:mod:`fl_design.sim._duration`).
    d_in : numpy.ndarray, optional
        ``(N,)`` input disturbance added to ``u`` at the plant (default zeros).
    disturbance_start : float, optional
        When the first non-zero disturbance acts (``inf``: none).
    metrics : tuple of str, optional
        The metrics asked for (None: all; the loop's kernel updates only their accumulators).

    Examples
    --------
    The maglev starts at its 6 mm gap: a 0.2 mm step, judged within 2 % of it.

    >>> import fl_design as fl
    >>> from fl_design.sim._run import prepare_run
    >>> run = prepare_run(fl.plants.maglev(), fl.presets.maglev_design(), fl.Scenario(6.2e-3, 0.5))
    >>> run.D.shape, run.y0, round(run.step, 6), round(run.tol, 9)
    ((3, 500), 0.006, 0.0002, 4e-06)
    """

    loop: ClosedLoop
    scenario: Scenario
    classifier: Classifier
    N: int
    r: np.ndarray
    noise: np.ndarray
    x0: np.ndarray
    s0: np.ndarray
    y0: float
    step: float
    tol: float
    q: float
    k_tail: int
    bound: np.ndarray
    region: np.ndarray
    duration_reason: str = "given"
    d_in: np.ndarray | None = None
    disturbance_start: float = math.inf
    metrics: tuple | None = None

    def __post_init__(self) -> None:
        if self.d_in is None:  # no input disturbance: zeros, one per sample
            object.__setattr__(self, "d_in", np.zeros(self.N))

    @property
    def T(self) -> float:
        """Sampling time."""
        return self.loop.T

    @property
    def duration(self) -> float:
        """Run length ``N T`` in seconds."""
        return self.N * self.loop.T

    @functools.cached_property
    def D(self) -> np.ndarray:
        """``(3, N)`` per-sample inputs ``(r_k, w_k, d_k)``: reference, what is added to the
        measurement (noise and output disturbance), what is added to ``u`` at the plant.

        Built once, sample-major in memory (a transposed view of a C-contiguous ``(N, 3)``
        array): the compiled runners read it, and any block of samples, without a copy.
        """
        return np.ascontiguousarray(np.column_stack([self.r, self.noise, self.d_in])).T

    @property
    def k_mid(self) -> int:
        """First sample of the second half of the tail window."""
        return self.k_tail + (self.N - self.k_tail) // 2

    @property
    def noise_level(self) -> float:
        """Standard deviation of the measurement error: noise and quantization (``q^2 / 12``)."""
        return float(np.hypot(self.scenario.noise.std, self.q / np.sqrt(12.0)))

    def constants(self) -> dict:
        """The run constants of the accumulator (``N k_tail k_mid y0 step tol noise k_dist``;
        ``k_dist`` the first sample of the disturbance, ``inf`` without one)."""
        k_dist = (float(round(self.disturbance_start / self.T))
                  if math.isfinite(self.disturbance_start) else math.inf)
        return {"N": float(self.N), "k_tail": float(self.k_tail), "k_mid": float(self.k_mid),
                "noise": self.noise_level,
                "y0": self.y0, "step": self.step, "tol": self.tol, "k_dist": k_dist}

    @property
    def u0(self) -> float:
        """The input before the first sample, ``u(-1)``."""
        return float(self.s0[self.loop.design.state_layout["u"]][0])

    def _design_states(self, P: np.ndarray) -> np.ndarray:
        """``s0``, or per column when an initial estimate depends on each column's ``eps``."""
        if self.scenario.initial_estimate is None:
            return self.s0
        design, n_est = self.loop.design, self.loop.n_p - 1
        cols, inverse = np.unique(P[:n_est], axis=1, return_inverse=True)
        states = np.column_stack([
            design.initial_state(y0=self.ym0, estimate=self.scenario.initial_estimate,
                                 u0=self.u0, params=c) for c in cols.T])
        return states[:, np.ravel(inverse)]

    @property
    def ym0(self) -> float:
        """The first measurement (noise and quantization included): the estimator's start."""
        return _measured(self.y0 + float(self.noise[0]), self.q)

    def initial_accumulator(self, P) -> np.ndarray:
        """``(nacc, m)`` accumulators for the parameter columns ``P`` (``(n_p, m)``).

        Parameters
        ----------
        P : array_like
            ``(n_p,)`` or ``(n_p, m)`` design parameter vectors.

        Returns
        -------
        numpy.ndarray
            One column per parameter vector, rows as the kernel's accumulator layout (plant
            and design state, previous input, metric accumulators, run constants).

        Examples
        --------
        See :mod:`fl_design.sim._run`.
        """
        P = np.asarray(P, dtype=float).reshape(self.loop.n_p, -1)
        return self.loop.layout.pack(
            x=self.x0, s=self._design_states(P), u_prev=self.u0, k=0.0,
            diverged=0.0, k_div=-1.0, **initial_values(self.loop.rho), **self.constants(),
            q=self.q, x_op=self.loop.plant.x_op, bound=self.bound, region_lo=self.region[0],
            region_hi=self.region[1], p=P,
        )


def prepare_run(plant, design, scenario: Scenario, *, integrator: RK4 | None = None,
                classifier: Classifier | None = None, gammas=None,
                allow_unmodeled: bool = False, metrics=None) -> RunSetup:
    """Validate a run of ``design`` on ``plant`` under ``scenario`` and lay out its samples.

    Parameters
    ----------
    plant : Plant
        The plant; its relative degree must equal ``design.rho`` (or exceed it, with
        ``allow_unmodeled``).
    design : Design
        Estimator + dynamic controller (its ``T`` is the loop's).
    scenario : Scenario
        Reference, duration, initial state and estimate, noise, quantization. Without a
        duration the run length is chosen here from the loop linearized at the design's own
        ``(eps, gamma)`` and the reference (:mod:`fl_design.sim._duration`), once for every
        run of a sweep.
    integrator : RK4, optional
        Substeps of the fixed-step integrator (default :class:`~fl_design.RK4`).
    classifier : Classifier, optional
        Tolerance, tail window and divergence bound (default :class:`~fl_design.Classifier`).
    gammas : array_like, optional
        The controller gains the run(s) will use (default the design's): each must have the
        sign of ``b`` (:func:`check_gamma_sign`).
    allow_unmodeled : bool, optional
        Accept a design of lower relative degree than the plant's (see
        :class:`~fl_design.sim.ClosedLoop`); default False.
    metrics : sequence of str, optional
        The metrics the runs must give (:func:`fl_design.sim._metrics.requested_metrics`;
        the status always): the kernel updates only their accumulators. Default None: all.

    Returns
    -------
    RunSetup

    Raises
    ------
    ParameterError
        A duration shorter than one sample, a plant, design or option object of the wrong
        type, a ``gamma`` whose sign is not that of ``b``, an unknown metric name.
    DimensionError
        A reference array or ``x0``, ``initial_estimate`` or bound of the wrong length.
    DesignMismatchError
        Relative degrees of plant and design differ (without ``allow_unmodeled``).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._run import prepare_run
    >>> d = fl.presets.pendulum_design()
    >>> sc = fl.Scenario(lambda t: 0.1 * (t > 0.5), 1.0)
    >>> prepare_run(fl.plants.pendulum(), d, sc).r[[0, -1]]
    array([0. , 0.1])
    """
    from ..design import Design
    from ..symbolic import Plant

    V.instance("plant", plant, Plant, "a fl.Plant (fl.Plant.from_ode or fl.plants.*)")
    V.instance("design", design, Design, "a fl.Design(estimator=..., controller=...)")
    scenario = V.instance("scenario", scenario, Scenario, "a fl.Scenario")
    integrator = option("integrator", integrator, RK4)
    classifier = option("classifier", classifier, Classifier)
    T = design.T
    if scenario.duration is not None:
        scenario.n_samples(T)  # a bad length is refused before the loop is built
    steps = resolve_substeps(plant, T, integrator.substeps)
    metrics = requested_metrics(metrics)
    loop = ClosedLoop(plant, design, substeps=steps,
                      allow_unmodeled=V.boolean("allow_unmodeled", allow_unmodeled),
                      accumulators=accumulators_for(metrics))
    check_gamma_sign(plant, design.controller.gamma if gammas is None else gammas)
    length = resolve_duration(loop, scenario, classifier)
    if length.adaptive:
        scenario = scenario.replace(duration=length.duration)
    N = scenario.n_samples(T)
    check_memory(8.0 * N * 3, f"a run of {N:.3g} samples (reference and noise)",
                 "shorten the run (Scenario duration) or sample slower (a larger T)")
    r = scenario.reference_samples(T)
    x0 = (plant.x_op.copy() if scenario.x0 is None
          else V.real_vector("x0", scenario.x0, length=plant.n))
    y0 = float(plant.casadi().h(x0))
    step = float(r[-1] - y0)
    scale = max(abs(step), float(np.ptp(r)))
    q = 0.0 if scenario.quantization is None else float(scenario.quantization)
    noise = scenario.noise.samples(N)
    d_in, d_start = np.zeros(N), math.inf
    if scenario.disturbance is not None:  # sampled once: a user's function is called once
        from ._disturbance import onset

        d_in, d_out = scenario.disturbance.sampled(T, N)
        d_start = onset(d_in, d_out, T)
        noise = noise + d_out
    s0 = _start_state(_measured(y0 + float(noise[0]), q), plant, design, scenario)
    return RunSetup(loop=loop, scenario=scenario, classifier=classifier, N=N, r=r, noise=noise,
                    d_in=d_in, disturbance_start=d_start,
                    x0=x0, s0=s0, y0=y0, step=step,
                    tol=float(classifier.tolerance) * (scale if scale > 0 else 1.0), q=q,
                    k_tail=classifier.k_tail(N), bound=classifier.bound_for(plant),
                    region=_region(plant), duration_reason=length.reason, metrics=metrics)


def _measured(y: float, q: float) -> float:
    """The quantized measurement ``q floor(y / q + 1/2)`` (``q = 0``: ``y``), as in the loop."""
    return float(q * np.floor(y / q + 0.5)) if q > 0 else float(y)


def _start_state(ym0: float, plant, design, scenario: Scenario) -> np.ndarray:
    ctrl = design.controller
    u0 = plant.u_eq if ctrl.u0 is None else ctrl.u0
    if ctrl.u_range is not None:
        u0 = float(np.clip(u0, *ctrl.u_range))
    estimate = scenario.initial_estimate
    if estimate is not None and np.size(estimate) != design.rho + 1:
        raise DimensionError(
            f"initial_estimate={np.ravel(estimate).tolist()} has {np.size(estimate)} entries; "
            f"the design (rho={design.rho}) needs rho + 1 = {design.rho + 1}: y, y', ..., "
            f"y^({design.rho - 1}), sigma")
    return design.initial_state(y0=ym0, estimate=estimate, u0=u0)


def signed_gammas(plant, gammas) -> np.ndarray:
    """The one gamma-sign rule: positive values are magnitudes that take the sign of ``b``.

    A grid given all negative (or on a plant whose sign of ``b`` is unknown) is kept as given.

    Parameters
    ----------
    plant : Plant
        The plant (its sign of ``b``: :func:`b_sign`).
    gammas : float or array_like
        Gains (nonzero).

    Returns
    -------
    numpy.ndarray
        The signed gains, same shape.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._run import signed_gammas
    >>> signed_gammas(fl.plants.maglev(), [1e-3, 2e-3]).tolist()
    [-0.001, -0.002]
    """
    grid = np.asarray(gammas, dtype=float)
    sign = b_sign(plant)
    if np.all(grid < 0) or sign == 0:
        return grid
    return sign * grid


def b_sign(plant) -> int:
    """The sign of ``b = d y^(rho)/du`` over the plant's region (+1 or -1; 0 if unknown).

    From :meth:`Plant.b_bounds` when the region bounds ``b``; else the sign at the operating
    point ``(x_op, u_eq)`` (a region that does not cover ``b``'s variables, or on which ``b``
    changes sign: there the method has no known sign, and the operating point's is used).

    Parameters
    ----------
    plant : Plant
        Its ``b`` over the region, or at the operating point.

    Returns
    -------
    int
        +1, -1, or 0 when neither the region nor the operating point gives a sign.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._run import b_sign
    >>> b_sign(fl.plants.pendulum())
    1
    """
    try:
        lo, _ = plant.b_bounds()
        return 1 if lo > 0 else -1
    except (ParameterError, RelativeDegreeError):
        b = float(plant.casadi().b(plant.x_op, plant.u_eq))
        return int(np.sign(b)) if np.isfinite(b) else 0


def check_gamma_sign(plant, gamma) -> None:
    """Refuse a ``gamma`` (or any of several) whose sign is not that of ``b`` on ``plant``.

    Parameters
    ----------
    plant : Plant
        Its ``b`` sets the valid sign (:func:`b_sign`).
    gamma : float or array_like
        The controller gain(s).

    Raises
    ------
    ParameterError
        Naming the gamma, the plant's ``b`` range and the valid sign.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._run import check_gamma_sign
    >>> check_gamma_sign(fl.plants.pendulum(), 1e-2)
    >>> check_gamma_sign(fl.plants.pendulum(), -1e-2)
    Traceback (most recent call last):
    ...
    fl_design.errors.ParameterError: gamma=-0.01 has the sign opposite to b ...
    """
    sign = b_sign(plant)
    g = np.atleast_1d(np.asarray(gamma, dtype=float))
    bad = g[np.sign(g) != sign] if sign else g[:0]
    if bad.size:
        try:
            where = "b in [{:.4g}, {:.4g}] over the region".format(*plant.b_bounds())
        except (ParameterError, RelativeDegreeError):
            where = "b at the operating point"
        word = "> 0" if sign > 0 else "< 0"
        raise ParameterError(
            f"gamma={bad[0]:g} has the sign opposite to b on plant {plant.name!r} ({where}): "
            f"gamma takes the sign of b; give gamma {word} (e.g. gamma={-bad[0]:g})")


def _region(plant) -> np.ndarray:
    ranges = list(plant._state_ranges()[0].values())  # without SymPy (a cached plant)
    return np.array([[-np.inf if r is None else r[0] for r in ranges],
                     [np.inf if r is None else r[1] for r in ranges]])


__all__ = ["RunSetup", "b_sign", "check_gamma_sign", "prepare_run"]
