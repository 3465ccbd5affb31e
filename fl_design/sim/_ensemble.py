"""The result of a Monte Carlo over a family of plants: :class:`Ensemble`.

Examples
--------
>>> import numpy as np
>>> from fl_design.sim._ensemble import Ensemble
>>> ens = Ensemble(params={"c": np.array([0.1, 0.9])}, status=np.array([2, -1]),
...                metrics={"tail_error": np.array([1e-4, np.nan]),
...                         "divergence_time": np.array([np.nan, 3.0])},
...                T=1e-3, duration=5.0, tol=np.array([2e-3, 2e-3]))
>>> ens.fractions["converged"], ens.worst(1)[0]["status"]
(0.5, 'diverged')
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import _validate as V
from .._frames import ColumnFrame
from .._json import jsonable
from ._status import CONVERGENT_CODES, Status

#: Severity of a verdict, worst first (for :meth:`Ensemble.worst`).
SEVERITY = (Status.DIVERGED, Status.SOLVER_FAILED, Status.OSCILLATING, Status.STALLED,
            Status.UNDECIDED, Status.CONVERGING, Status.CONVERGED)


@dataclass(frozen=True)
class Ensemble(ColumnFrame):
    """Verdicts and metrics of one design run against every plant of a family.

    Parameters
    ----------
    params : dict
        ``{parameter name: (n,) values}`` of each sample (``plant.with_params(**sample)``).
    status : numpy.ndarray
        ``(n,)`` codes of :class:`fl_design.sim.Status`.
    metrics : dict
        Name -> ``(n,)`` array (``estimation_rms``: ``(n, rho + 1)``), as
        :attr:`fl_design.Response.metrics` per sample.
    T, duration : float
        Sampling time and run length (the same for every sample).
    tol : numpy.ndarray
        ``(n,)`` absolute tolerance of each run (its step may depend on the parameters).
    distributions : dict, optional
        ``{name: description}`` of what the samples were drawn from.
    seed : int or None, optional
        The seed of the draw.
    duration_reason : str, optional
        ``"given"`` or how the run length was chosen (on the nominal plant).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._ensemble import Ensemble
    >>> ens = Ensemble({"b": np.array([0.9, 1.1, 1.0])}, np.array([2, 1, 2]), {}, 1e-3, 1.0,
    ...                np.full(3, 1e-3))
    >>> ens.n, ens.convergent_fraction, ens.sample(1)
    (3, 1.0, {'b': 1.1})
    """

    _FRAME_INSTEAD = "to_dict columns"

    params: dict
    status: np.ndarray
    metrics: dict = field(repr=False)
    T: float
    duration: float
    tol: np.ndarray = field(repr=False)
    distributions: dict = field(default_factory=dict)
    seed: int | None = None
    duration_reason: str = "given"

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(np.size(self.status))

    @property
    def labels(self) -> np.ndarray:
        """``status`` as strings (``'converged'``, ``'diverged'``, ...)."""
        return np.array([Status(int(c)).label for c in np.ravel(self.status)], dtype=str)

    @property
    def fractions(self) -> dict:
        """``{verdict: fraction of the samples}`` for every verdict (0.0 when absent)."""
        codes = np.asarray(self.status)
        return {s.label: float(np.mean(codes == int(s))) if self.n else 0.0
                for s in reversed(SEVERITY)}

    @property
    def convergent_fraction(self) -> float:
        """Fraction of samples that converge (converged or converging)."""
        return float(np.mean(np.isin(self.status, CONVERGENT_CODES))) if self.n else 0.0

    def sample(self, i: int) -> dict:
        """``{name: value}`` of sample ``i`` (``plant.with_params(**ens.sample(i))``).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim._ensemble import Ensemble
        >>> Ensemble({"c": np.array([0.5])}, np.array([2]), {}, 1e-3, 1.0, np.ones(1)).sample(0)
        {'c': 0.5}
        """
        i = V.integer("i", i, minimum=-self.n, maximum=self.n - 1)
        return {k: float(v[i]) for k, v in self.params.items()}

    def worst(self, k: int = 5) -> list[dict]:
        """The ``k`` worst samples: by verdict (diverged first, earliest divergence first),
        then by ``tail_error`` (largest first).

        Parameters
        ----------
        k : int, optional
            How many (default 5).

        Returns
        -------
        list of dict
            ``index``, ``status``, the parameters, ``tail_error``, ``divergence_time``.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim._ensemble import Ensemble
        >>> ens = Ensemble({"c": np.array([0.1, 0.2])}, np.array([2, 2]),
        ...                {"tail_error": np.array([1e-4, 5e-4])}, 1e-3, 1.0, np.ones(2))
        >>> [w["index"] for w in ens.worst(2)]
        [1, 0]
        """
        k = V.integer("k", k, minimum=0)
        codes = np.asarray(self.status)
        rank = np.array([SEVERITY.index(Status(int(c))) for c in codes])
        tail = np.nan_to_num(np.asarray(self.metrics.get("tail_error", np.zeros(self.n))),
                             nan=-np.inf)
        div = np.nan_to_num(np.asarray(self.metrics.get("divergence_time",
                                                        np.full(self.n, np.nan))), nan=np.inf)
        order = np.lexsort((-tail, div, rank))[:k]
        return [{"index": int(i), "status": Status(int(codes[i])).label, **self.sample(int(i)),
                 "tail_error": float(tail[i]) if np.isfinite(tail[i]) else float("nan"),
                 "divergence_time": float(div[i]) if np.isfinite(div[i]) else float("nan")}
                for i in order]

    def columns(self) -> dict:
        """One column per parameter, ``status`` (labels), ``tol`` and metric (a per-estimate
        metric as ``estimation_rms_0`` ...), each of length ``n``."""
        out = {k: np.asarray(v, dtype=float) for k, v in self.params.items()}
        out["status"] = self.labels
        out["tol"] = np.asarray(self.tol, dtype=float)
        for name, value in self.metrics.items():
            value = np.asarray(value, dtype=float)
            if value.ndim == 2:
                out.update({f"{name}_{j}": value[:, j] for j in range(value.shape[1])})
            else:
                out[name] = value
        return out

    def to_dict(self) -> dict:
        """Samples, verdicts, metrics and the verdict fractions as plain JSON types.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim._ensemble import Ensemble
        >>> d = Ensemble({"c": np.array([0.5])}, np.array([-1]), {}, 1e-3, 1.0,
        ...              np.ones(1)).to_dict()
        >>> d["status"], d["fractions"]["diverged"]
        (['diverged'], 1.0)
        """
        return jsonable({"n": self.n, "seed": self.seed, "T": self.T, "duration": self.duration,
                         "duration_reason": self.duration_reason,
                         "distributions": {k: str(v) for k, v in self.distributions.items()},
                         "params": self.params, "status": self.labels.tolist(),
                         "tol": self.tol, "fractions": self.fractions,
                         "worst": self.worst(), "metrics": self.metrics})

    def _repr_html_(self) -> str:
        """A short HTML table for Jupyter: the family, the runs, the verdict fractions."""
        from ._response import _html_table

        rows = [("plants", f"{self.n}: " + ", ".join(f"{k} ~ {v}" for k, v in
                                                    self.distributions.items())),
                ("runs", f"{self.duration:g} s each, T = {self.T:g} s, seed {self.seed}")]
        return _html_table(rows + [(k, f"{100 * v:.1f} %") for k, v in self.fractions.items()
                                   if v > 0])

    def __str__(self) -> str:
        parts = [f"{100 * v:.1f}% {k}" for k, v in self.fractions.items() if v > 0]
        return f"{self.n} plants ({', '.join(self.params)}): " + ", ".join(parts)

    def plot(self, *, metrics=("tail_error", "settling_time", "input_rms"), x=None, y=None):
        """Histograms of ``metrics`` and the verdict of each sample over two parameters.

        Parameters
        ----------
        metrics : sequence of str, optional
            Metrics to histogram (finite values only).
        x, y : str, optional
            Parameters of the scatter plot (default the first two; with one parameter,
            verdict against it).

        Returns
        -------
        matplotlib.figure.Figure
            One histogram per metric, then the scatter of the verdicts over ``x`` and ``y``.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim._ensemble import Ensemble
        >>> ens = Ensemble({"c": np.array([0.1, 0.5]), "b": np.array([1.0, 1.1])},
        ...                np.array([2, -1]), {"tail_error": np.array([1e-4, np.nan])},
        ...                1e-3, 1.0, np.ones(2))
        >>> len(ens.plot(metrics=("tail_error",)).axes)
        2
        """
        from ..plotting import plot_ensemble

        return plot_ensemble(self, metrics=metrics, x=x, y=y)


__all__ = ["Ensemble"]
