"""Monte Carlo over uncertain plant parameters: one design against a family of plants.

:func:`monte_carlo` draws ``n`` plants ``plant.with_params(**sample)`` from the given
distributions (seeded) and runs the design on every one in the compiled sweep kernel: the
plant's uncertain parameters are run-time inputs of that kernel (one build, no recompilation
per sample; :mod:`fl_design.sim._family`), the runs are columns as the grid points of
:func:`fl_design.sweep` (same lanes, threads and executors), and each is classified as
:func:`fl_design.simulate` classifies it. The result is an :class:`~fl_design.sim.Ensemble`.

Examples
--------
>>> import fl_design as fl
>>> ens = fl.monte_carlo(fl.plants.pendulum(), fl.presets.pendulum_design(),
...                      fl.Scenario(0.1, 3.0), params={"c": (0.05, 1.0),
...                      "b": fl.Normal(1.0, 0.1)}, n=8, seed=0, progress=False)
>>> ens.n, ens.fractions["converged"] + ens.fractions["converging"]
(8, 1.0)
"""

from __future__ import annotations

import math
from concurrent.futures import Executor

import numpy as np

from .. import _validate as V
from ..errors import WorkerLostError
from ._disturbance import summary_metrics
from ._ensemble import Ensemble
from ._family import draw, parse_distributions, prepare_family
from ._grid import run_grid
from ._metrics import metrics_from_summary
from ._options import RK4, Classifier, Kernel, Scenario
from ._partial import PartialEnsemble, finished_only, lost_mask, reason_of


class _SampleColumns:
    """Columns ``[p; i]`` of the samples, built chunk by chunk (a column source of run_grid)."""

    def __init__(self, family, p):
        self.family, self.p, self.n = family, np.asarray(p, dtype=float), family.n_samples

    def __call__(self, a: int, b: int) -> np.ndarray:
        return self.family.columns(self.p, np.arange(a, b))

    def take(self, idx) -> np.ndarray:
        return self.family.columns(self.p, np.asarray(idx))


def summarize(family, acc: np.ndarray) -> tuple[np.ndarray, dict]:
    """``(status, metrics)`` of final accumulators ``acc`` (one column per run); with a
    disturbance in the scenario, ``disturbance_peak`` and ``recovery_time`` too.

    Examples
    --------
    >>> from fl_design.sim._monte_carlo import summarize
    >>> callable(summarize)
    True
    """
    info = family.loop.layout.unpack(acc)
    info["est2_sum"] = np.asarray(info["est2_sum"]).T
    m = metrics_from_summary(info, family.T)
    if math.isfinite(family.disturbance_start):  # the response to the scenario's disturbance
        m.update(summary_metrics(info, family.T, family.disturbance_start))
    return m.pop("status"), m


def monte_carlo(plant, design, scenario: Scenario, *, params: dict, n: int = 1000,
                seed: int = 0, executor: Executor | None = None,
                integrator: RK4 | None = None, classifier: Classifier | None = None,
                kernel: Kernel | None = None, progress: bool = True,
                allow_unmodeled: bool = False) -> Ensemble:
    """Run ``design`` against ``n`` plants drawn from parameter distributions.

    Sample ``i`` is the plant ``plant.with_params(**ens.sample(i))``: its run equals
    :func:`fl_design.simulate` of that plant (same samples, noise, integrator and
    classification; the equilibrium input and the initial output are the sample's own), up
    to the last bits of the arithmetic.

    Parameters
    ----------
    plant : Plant
        The nominal plant (its operating point is every sample's).
    design : Design
        The design, unchanged for every sample.
    scenario : Scenario
        Reference, duration, noise, disturbance of every run. Without a duration the run
        length is chosen once, on the nominal plant.
    params : dict
        ``{parameter name: distribution}``: ``(lo, hi)`` or :class:`fl_design.Uniform`,
        :class:`fl_design.Normal`; drawn in this order from one generator.
    n : int, optional
        Number of plants (default 1000).
    seed : int, optional
        Seed of the draw (default 0): the same seed gives the same plants.
    executor : concurrent.futures.Executor, optional
        Runs chunks of samples as tasks, as in :func:`fl_design.sweep`.
    integrator, classifier, kernel : optional
        As for :func:`fl_design.sweep`.
    progress : bool, optional
        Progress bar (default True).
    allow_unmodeled : bool, optional
        As for :func:`fl_design.sweep`.

    Returns
    -------
    Ensemble

    Raises
    ------
    ParameterError
        Unknown parameter names, bad distributions, ``n < 1``, a negative seed, samples whose
        ``b`` has the sign opposite to the nominal plant's.
    PlantDefinitionError
        A sample without an equilibrium input at the operating point.

    Examples
    --------
    >>> import fl_design as fl
    >>> ens = fl.monte_carlo(fl.plants.pendulum(), fl.presets.pendulum_design(),
    ...                      fl.Scenario(0.1, 2.0), params={"c": (0.1, 0.9)}, n=4,
    ...                      progress=False)
    >>> sorted(ens.params), ens.status.shape
    (['c'], (4,))
    """
    from ..symbolic import Plant

    V.instance("plant", plant, Plant, "a fl.Plant (fl.Plant.from_ode or fl.plants.*)")
    dists = parse_distributions(plant, params)
    n = V.integer("n", n, minimum=1)
    seed = V.integer("seed", seed, minimum=0)
    values = draw(dists, n, seed)
    family = prepare_family(plant, design, scenario, values, integrator=integrator,
                            classifier=classifier, allow_unmodeled=allow_unmodeled)
    def result(status, metrics, lost=None, reason=""):
        cls, extra = ((Ensemble, {}) if lost is None else
                      (PartialEnsemble, {"lost": lost, "lost_reason": reason}))
        return cls(params=values, status=status, metrics=metrics, T=family.T,
                   duration=family.duration, tol=family.tols, distributions=dists, seed=seed,
                   duration_reason=family.duration_reason, **extra)

    try:
        acc = run_grid(family, _SampleColumns(family, design.parameter_vector()),
                       kernel=kernel, executor=executor, progress=progress,
                       desc="monte carlo")
    except WorkerLostError as err:  # the finished chunks (fl_design.sim._partial)
        lost = lost_mask(err, err.accumulators.shape[1])
        status, metrics = finished_only(lambda a: summarize(family, a), err.accumulators,
                                        lost, getattr(err, "probe", None))
        raise err.with_partial(result(status, metrics, lost, reason_of(err))) from None
    return result(*summarize(family, acc))


__all__ = ["monte_carlo"]
