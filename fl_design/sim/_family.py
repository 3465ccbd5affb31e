"""A family of plants: parameter distributions, seeded draws, and the runs of every member.

A Monte Carlo (:func:`fl_design.monte_carlo`) or a robust map (:func:`fl_design.sweep` with
``params``) runs one design against many plants ``plant.with_params(**sample)``. The plant's
uncertain parameters are *run-time inputs* of the compiled kernel (the accumulator's
``theta``, :class:`~fl_design.sim.ClosedLoop` ``uncertain``): one build serves every sample.
What depends on the parameters is computed per sample here, as ``with_params`` and
:func:`~fl_design.sim._run.prepare_run` would: the equilibrium input ``u_eq`` at the (fixed)
operating point, hence the design's initial input; the initial output ``h(x0)``, hence the
step and the tolerance band. Everything else (samples, duration, noise, bounds) is the
nominal plant's, shared by every run.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim._family import draw, parse_distributions
>>> dists = parse_distributions(fl.plants.pendulum(), {"c": (0.1, 1.0), "b": fl.Normal(1, 0.1)})
>>> values = draw(dists, 4, seed=0)
>>> sorted(values), values["c"].shape
(['b', 'c'], (4,))
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .. import _validate as V
from ..errors import ParameterError, PlantDefinitionError
from ._run import RunSetup, _measured, b_sign
from .kernel._loop import ClosedLoop
from .kernel._parametric import parametric_plant


@dataclass(frozen=True)
class Uniform:
    """A parameter uniformly distributed on ``[lo, hi]`` (a tuple ``(lo, hi)`` means this).

    Parameters
    ----------
    lo, hi : float
        Finite bounds, ``lo < hi``.

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> fl.Uniform(0.5, 1.0).sample(np.random.default_rng(0), 3).round(3).tolist()
    [0.818, 0.635, 0.52]
    """

    lo: float
    hi: float

    def __post_init__(self) -> None:
        lo, hi = V.real_scalar("Uniform lo", self.lo), V.real_scalar("Uniform hi", self.hi)
        if not lo < hi:
            raise ParameterError(f"Uniform needs lo < hi, got lo={lo!r}, hi={hi!r}")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` draws from ``rng``."""
        return rng.uniform(self.lo, self.hi, n)

    def __str__(self) -> str:
        return f"Uniform({self.lo:g}, {self.hi:g})"


@dataclass(frozen=True)
class Normal:
    """A normally distributed parameter, mean ``mu`` and standard deviation ``sigma``.

    Parameters
    ----------
    mu : float
        Mean (finite).
    sigma : float
        Standard deviation (> 0).

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> fl.Normal(1.0, 0.1).sample(np.random.default_rng(0), 2).round(3).tolist()
    [1.013, 0.987]
    """

    mu: float
    sigma: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "mu", V.real_scalar("Normal mu", self.mu))
        object.__setattr__(self, "sigma", V.positive("Normal sigma", self.sigma))

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` draws from ``rng``."""
        return rng.normal(self.mu, self.sigma, n)

    def __str__(self) -> str:
        return f"Normal({self.mu:g}, {self.sigma:g})"


def parse_distributions(plant, params) -> dict:
    """``{name: Uniform or Normal}`` from ``params`` (a tuple ``(lo, hi)`` is uniform).

    Parameters
    ----------
    plant : Plant
        The plant whose parameters are named.
    params : dict
        ``{parameter name: (lo, hi) | fl.Uniform | fl.Normal}``, at least one.

    Returns
    -------
    dict

    Raises
    ------
    ParameterError
        Not a dict, empty, an unknown name (the plant's are listed) or a value that is no
        distribution.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._family import parse_distributions
    >>> parse_distributions(fl.plants.pendulum(), {"c": (0.1, 1.0)})
    {'c': Uniform(lo=0.1, hi=1.0)}
    """
    if not isinstance(params, dict) or not params:
        raise ParameterError(f"params must be a non-empty dict {{parameter name: (lo, hi) or "
                             f"fl.Normal(mu, sigma)}}, got {V.short(params)}")
    known = sorted(sym.name for sym in plant.params)
    out = {}
    for name, dist in params.items():
        if name not in known:
            raise ParameterError(f"params names {name!r}, not a parameter of plant "
                                 f"{plant.name!r}; its parameters are {known}")
        if isinstance(dist, (tuple, list)) and len(dist) == 2:
            dist = Uniform(*dist)
        if not isinstance(dist, (Uniform, Normal)):
            raise ParameterError(f"params[{name!r}] must be (lo, hi), fl.Uniform(lo, hi) or "
                                 f"fl.Normal(mu, sigma), got {V.short(dist)}")
        out[name] = dist
    return out


def draw(dists: dict, n: int, seed: int) -> dict:
    """``{name: (n,) values}``: the parameters drawn in order from one seeded generator.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._family import draw
    >>> draw({"c": fl.Uniform(0, 1)}, 2, seed=1)["c"].round(3).tolist()
    [0.512, 0.95]
    """
    rng = np.random.default_rng(seed)
    return {name: dist.sample(rng, n) for name, dist in dists.items()}


@dataclass(frozen=True)
class FamilySetup(RunSetup):
    """A :class:`~fl_design.sim._run.RunSetup` whose runs differ in plant parameters.

    A run's column is the design's parameter vector followed by the index of its sample
    (:meth:`columns`); :meth:`initial_accumulator` puts that sample's ``theta``, initial input,
    initial output, step and tolerance into the accumulator.

    Parameters
    ----------
    theta : numpy.ndarray
        ``(n_theta, n)`` parameter values (rows in the order of ``loop.uncertain``).
    u0s, y0s, steps, tols : numpy.ndarray
        ``(n,)`` per sample: input before the first sample, initial output, step, tolerance.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._family import prepare_family
    >>> d = fl.presets.pendulum_design()
    >>> fam = prepare_family(fl.plants.pendulum(), d, fl.Scenario(0.1, 1.0),
    ...                      {"c": [0.1, 0.2, 0.3]})
    >>> fam.initial_accumulator(fam.columns(d.parameter_vector(), 3)).shape
    (107, 3)
    """

    theta: np.ndarray = None
    u0s: np.ndarray = None
    y0s: np.ndarray = None
    steps: np.ndarray = None
    tols: np.ndarray = None

    @property
    def n_samples(self) -> int:
        """Number of plants of the family."""
        return int(self.theta.shape[1])

    def columns(self, p, samples) -> np.ndarray:
        """Columns ``[p; i]`` for the design parameters ``p`` and each sample index.

        ``samples`` is an int (all ``0 .. samples - 1``) or an array of indices.
        """
        idx = np.arange(samples) if np.ndim(samples) == 0 else np.asarray(samples)
        p = np.asarray(p, dtype=float).reshape(-1, 1)
        return np.vstack([np.repeat(p, idx.size, axis=1), idx[None, :].astype(float)])

    def initial_accumulator(self, P) -> np.ndarray:
        """``(nacc, m)`` accumulators of the columns ``P`` (``(n_p + 1, m)``: :meth:`columns`)."""
        n_p, lay = self.loop.n_p, self.loop.layout
        P = np.asarray(P, dtype=float).reshape(n_p + 1, -1)
        idx = P[-1].astype(np.int64)
        Pd = P[:-1]
        ym0 = np.array([_measured(y + float(self.noise[0]), self.q) for y in self.y0s[idx]])
        states = self._family_states(Pd, ym0, self.u0s[idx])
        const = {**self.constants(), "y0": self.y0s[idx][None, :],
                 "step": self.steps[idx][None, :], "tol": self.tols[idx][None, :]}
        return lay.pack(
            x=self.x0, s=states, u_prev=self.u0s[idx][None, :], k=0.0, diverged=0.0,
            k_div=-1.0, **_initial(self.loop.rho), **const,
            q=self.q, x_op=self.loop.plant.x_op, bound=self.bound, region_lo=self.region[0],
            region_hi=self.region[1], p=Pd, theta=self.theta[:, idx])

    def _family_states(self, Pd, ym0, u0) -> np.ndarray:
        design, est = self.loop.design, self.scenario.initial_estimate
        n_est = self.loop.n_p - 1
        keys = np.vstack([ym0, u0, Pd[:n_est]]) if est is not None else np.vstack([ym0, u0])
        uniq, inverse = np.unique(keys, axis=1, return_inverse=True)
        states = np.column_stack([
            design.initial_state(y0=float(c[0]), estimate=est, u0=float(c[1]),
                                 params=c[2:] if est is not None else None) for c in uniq.T])
        return states[:, np.ravel(inverse)]


def _initial(rho: int) -> dict:
    from ._metrics import initial_values

    return initial_values(rho)


def prepare_family(plant, design, scenario, values: dict, **options) -> FamilySetup:
    """The runs of ``design`` on ``plant.with_params(**sample)`` for every sample of ``values``.

    Parameters
    ----------
    plant, design, scenario
        As for :func:`~fl_design.sim._run.prepare_run` (the duration, if adaptive, is chosen
        once on the nominal plant).
    values : dict
        ``{parameter name: (n,) values}``.
    **options
        ``integrator``, ``classifier``, ``allow_unmodeled``, ``gammas`` of ``prepare_run``.

    Returns
    -------
    FamilySetup

    Raises
    ------
    PlantDefinitionError
        A sample has no equilibrium input at the operating point (the message names it).
    ParameterError
        A sample's ``b`` at the operating point has the sign opposite to the nominal plant's
        (gamma takes the sign of ``b``: no one design serves both).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._family import prepare_family
    >>> fam = prepare_family(fl.plants.pendulum(), fl.presets.pendulum_design(),
    ...                      fl.Scenario(0.1, 1.0), {"b": [0.9, 1.1]})
    >>> fam.n_samples, fam.loop.uncertain
    (2, ('b',))
    """
    from ._run import prepare_run

    nominal = prepare_run(plant, design, scenario, **options)
    names = tuple(values)
    theta = np.vstack([np.asarray(values[k], dtype=float).ravel() for k in names])
    if not np.all(np.isfinite(theta)):
        raise ParameterError("the sampled plant parameters must be finite")
    loop = ClosedLoop(plant, design, substeps=nominal.loop.substeps,
                      allow_unmodeled=nominal.loop.allow_unmodeled, uncertain=names)
    fns = parametric_plant(plant, names, loop.rho)
    u_eq = _equilibrium_inputs(plant, fns["f"], theta, names)
    _check_b_signs(plant, fns["b"], u_eq, theta, names, options.get("gammas"))
    ctrl = design.controller
    u0s = np.full(theta.shape[1], ctrl.u0) if ctrl.u0 is not None else u_eq.copy()
    if ctrl.u_range is not None:
        u0s = np.clip(u0s, *ctrl.u_range)
    y0s = np.asarray(fns["h"].map(theta.shape[1])(nominal.x0, theta), dtype=float).ravel()
    r = nominal.r
    steps = r[-1] - y0s
    scales = np.maximum(np.abs(steps), float(np.ptp(r)))
    tols = float(nominal.classifier.tolerance) * np.where(scales > 0, scales, 1.0)
    fields = {f.name: getattr(nominal, f.name) for f in dataclasses.fields(RunSetup)}
    fields["loop"] = loop
    return FamilySetup(**fields, theta=theta, u0s=u0s, y0s=y0s, steps=steps, tols=tols)


def _equilibrium_inputs(plant, f, theta, names) -> np.ndarray:
    """``u_eq`` per sample: ``f(x_op, u, theta) = 0`` by Gauss-Newton from the nominal
    ``u_eq`` (exact in one step for an input-affine plant), else ``with_params``'s own solve
    (which raises a clear error when there is none)."""
    n = theta.shape[1]
    newton, f0 = _newton(f, tuple(plant.x_op), theta.shape[0])
    many = newton.map(n)
    ue = np.full(n, plant.u_eq)
    scale = np.maximum(1.0, np.max(np.abs(np.asarray(f0.map(n)(theta), dtype=float)), axis=0))
    for _ in range(8):
        with np.errstate(all="ignore"):
            nxt, res = (np.asarray(v, dtype=float) for v in many(ue[None, :], theta))
        resid = np.max(np.abs(res), axis=0)
        if np.all(resid <= 1e-9 * scale):
            break
        ue = np.where(np.isfinite(nxt.ravel()), nxt.ravel(), ue)
    lo, hi = plant.input_range or (-math.inf, math.inf)
    bad = np.flatnonzero(~((resid <= 1e-9 * scale) & (ue >= lo) & (ue <= hi)))
    for i in bad:  # rare: the plant's own solver decides, and names what is wrong
        sample = {k: float(theta[j, i]) for j, k in enumerate(names)}
        try:
            ue[i] = plant.with_params(**sample).u_eq
        except PlantDefinitionError as exc:
            raise PlantDefinitionError(f"sample {i} of the family ({sample}): {exc}") from None
    return np.where(np.abs(ue) < 1e-12, 0.0, ue)


@functools.lru_cache(maxsize=16)
def _newton(f, x_op: tuple, n_theta: int):
    """``(newton, f0)``: one Gauss-Newton step ``u -> u - J' r / J' J`` with the residual
    ``r = f(x_op, u, theta)`` before it, and ``f(x_op, 0, theta)`` (the residual's scale)."""
    u, th = ca.SX.sym("u"), ca.SX.sym("theta", n_theta)
    res = f(list(x_op), u, th)
    jac = ca.jacobian(res, u)
    newton = ca.Function("fl_ueq", [u, th], [u - ca.dot(jac, res) / ca.sumsqr(jac), res])
    return newton, ca.Function("fl_f0", [th], [f(list(x_op), 0.0, th)])


def _check_b_signs(plant, b, u_eq, theta, names, gammas) -> None:
    if b is None:
        return
    sign = b_sign(plant)
    values = np.asarray(b.map(theta.shape[1])(plant.x_op, u_eq[None, :], theta),
                        dtype=float).ravel()
    bad = np.flatnonzero(np.sign(values) != sign) if sign else np.array([], dtype=int)
    if bad.size:
        i = int(bad[0])
        sample = {k: float(theta[j, i]) for j, k in enumerate(names)}
        raise ParameterError(
            f"{bad.size} sample(s) of the family have b of the sign opposite to the nominal "
            f"plant's at the operating point (e.g. sample {i}, {sample}: b={values[i]:.4g}); "
            "gamma takes the sign of b, so no one design serves them: choose distributions "
            "that keep the sign of b (e.g. a Uniform interval, or a smaller sigma)")


__all__ = ["FamilySetup", "Normal", "Uniform", "draw", "parse_distributions", "prepare_family"]
