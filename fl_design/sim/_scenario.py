"""What one run does: :class:`Scenario` (reference, duration, start) and its :class:`Noise`.

Examples
--------
A reference may be a function of time, sampled at ``t = kT``:

>>> import fl_design as fl
>>> fl.Scenario(lambda t: 0.1 * (t >= 2e-3), 5e-3).reference_samples(1e-3).tolist()
[0.0, 0.0, 0.1, 0.1, 0.1]
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass, field
from typing import Any

import numpy as np

from .. import _validate as V
from .._json import jsonable
from .._limits import env_limit
from ..errors import DimensionError, ParameterError, ResourceLimitError

#: Environment variable lifting the default limit :data:`MAX_SAMPLES` on a run's length.
MAX_SAMPLES_ENV = "FL_DESIGN_MAX_SAMPLES"
#: Default largest number of samples of one run (10^8: 1.6 GB of inputs, ~28 h at 1 kHz).
MAX_SAMPLES = 10**8


def max_samples() -> int:
    """Largest accepted run length: ``$FL_DESIGN_MAX_SAMPLES`` if set, else :data:`MAX_SAMPLES`.

    Returns
    -------
    int
        The limit in samples per run.

    Examples
    --------
    >>> from fl_design.sim._scenario import max_samples
    >>> max_samples() >= 10**6
    True
    """
    return env_limit(MAX_SAMPLES_ENV, MAX_SAMPLES, unit="samples")


@dataclass(frozen=True)
class Noise:
    """Additive white Gaussian measurement noise ``w_k = std * N(0, 1)``, reproducible.

    Parameters
    ----------
    std : float, optional
        Standard deviation (>= 0; default 0: no noise). The paper's "variance 0.001" is
        ``std = sqrt(1e-3)``.
    seed : int, optional
        Seed of ``numpy.random.default_rng`` (>= 0; default 0).

    Raises
    ------
    ParameterError
        Negative or non-finite ``std``, or a ``seed`` that is not a non-negative integer.

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.Noise(std=0.1, seed=3).samples(3).round(3)
    array([ 0.204, -0.256,  0.042])
    """

    std: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        V.nonnegative("noise std", self.std)
        V.integer("noise seed", self.seed, minimum=0)

    def samples(self, n: int) -> np.ndarray:
        """``n`` noise samples (zeros when ``std == 0``).

        Parameters
        ----------
        n : int
            Number of samples.

        Returns
        -------
        numpy.ndarray
            ``(n,)`` Gaussian samples of standard deviation :attr:`std`, drawn from
            :attr:`seed` (the same seed gives the same samples).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Noise().samples(2)
        array([0., 0.])
        """
        std = float(self.std)
        if std == 0.0:
            return np.zeros(n)
        return std * np.random.default_rng(int(self.seed)).standard_normal(n)

    def to_dict(self) -> dict:
        """Strict-JSON fields.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Noise(0.1, 2).to_dict()
        {'std': 0.1, 'seed': 2}
        """
        return {"std": float(self.std), "seed": int(self.seed)}


@dataclass(frozen=True)
class Scenario:
    """What one closed-loop run does: reference, duration, start, measurement imperfections.

    Parameters
    ----------
    reference : float, callable or array_like
        A constant (a step at t = 0 from the initial output), a function ``r(t)`` sampled at
        ``t = kT``, or ``N = round(duration / T)`` samples.
    duration : float, optional
        Length of the run in seconds (> 0; at least one sample of the design's ``T``).
        Omitted (None): chosen by the run from the loop's slowest time constant at the
        design point and the reference (:mod:`fl_design.sim._duration`: 7.8 time constants
        with the default classifier, clamped, a fixed 20 s when the linearized loop is
        unstable); :attr:`fl_design.Response.duration_reason` says what was chosen and why.
        An array reference fixes the length and needs ``duration``.
    x0 : array_like, optional
        Initial plant state (default: the plant's operating point).
    noise : Noise, optional
        Measurement noise (default none).
    quantization : float, optional
        Quantization step of the measurement, > 0 (default none): ``q floor(y/q + 1/2)``.
    initial_estimate : array_like, optional
        The estimator's first estimates ``(y, y', ..., y^(rho-1), sigma)``, ``rho + 1``
        values (checked against the design by the run). Default: a bumpless start at rest at
        the first measurement, ``(y_0, 0, ..., 0)``.
    disturbance : Disturbance, optional
        Input and output disturbances (:class:`fl_design.Disturbance`: steps, sines, sampled
        arrays or functions of t), in the compiled kernel, the interpreter and ``cvodes``
        alike; :attr:`fl_design.Response.disturbance` measures the peak deviation and the
        recovery time. Default none.

    Raises
    ------
    ParameterError
        Non-positive or non-finite duration, an array reference without a duration, a
        non-finite constant reference or ``x0``,
        ``noise`` not a :class:`Noise`, a non-positive quantization.
    DimensionError
        A reference array, ``x0`` or ``initial_estimate`` that is not one-dimensional.

    Examples
    --------
    >>> import fl_design as fl
    >>> sc = fl.Scenario(lambda t: 0.3 * (t >= 1.0), 5.0)
    >>> sc.reference_samples(1.0)
    array([0. , 0.3, 0.3, 0.3, 0.3])
    >>> fl.Scenario(0.3).duration is None  # adaptive: the run chooses its length
    True
    """

    reference: Any
    duration: float | None = None
    _: KW_ONLY
    x0: Any = None
    noise: Noise = field(default_factory=Noise)
    quantization: float | None = None
    initial_estimate: Any = None
    disturbance: Any = None

    def __post_init__(self) -> None:
        if self.disturbance is not None:
            from ._disturbance import Disturbance

            if not isinstance(self.disturbance, Disturbance):
                raise ParameterError(f"disturbance must be a fl.Disturbance(input=..., "
                                     f"output=...), got {self.disturbance!r}")
        if self.duration is not None:
            V.positive("duration", self.duration)
        ref = self.reference
        if isinstance(ref, str) or ref is None:
            raise ParameterError(
                f"reference must be a number, a callable r(t) or an array of samples, got {ref!r}")
        if not callable(ref):
            if np.ndim(ref) == 0:
                V.real_scalar("reference", ref)
            else:
                V.real_vector("reference", ref)
                if self.duration is None:
                    raise ParameterError(
                        f"an array reference ({np.size(ref)} samples) fixes the run's length: "
                        "give duration = len(reference) * T (the adaptive duration needs a "
                        "constant or callable reference)")
        if self.x0 is not None:
            V.real_vector("x0", self.x0)
        if not isinstance(self.noise, Noise):
            raise ParameterError(f"noise must be a fl.Noise(std, seed), got {self.noise!r}")
        if self.quantization is not None:
            V.positive("quantization", self.quantization)
        if self.initial_estimate is not None:
            V.real_vector("initial_estimate", self.initial_estimate)

    def n_samples(self, T: float) -> int:
        """``N = round(duration / T)``, the number of samples at sampling time ``T``.

        Parameters
        ----------
        T : float
            Sampling time.

        Returns
        -------
        int
            ``N >= 1``, at most :func:`max_samples`.

        Raises
        ------
        ParameterError
            The duration is shorter than one sample, or not set (adaptive: resolved by
            :func:`fl_design.sim._run.prepare_run`).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Scenario(0.0, 1.0).n_samples(1e-3)
        1000
        """
        if self.duration is None:
            raise ParameterError(
                "this Scenario has no duration (adaptive: fl.simulate, fl.sweep and "
                "fl.estimate_eps_star choose it from the loop); give Scenario(..., "
                "duration=...) to count its samples here")
        N = round(float(self.duration) / T)
        if float(self.duration) < T * (1.0 - 1e-9) or N < 1:
            raise ParameterError(
                f"duration={self.duration!r} is shorter than one sample (T={T!r}); give a "
                f"duration >= T")
        limit = max_samples()
        if N > limit:
            raise ResourceLimitError(
                f"duration={self.duration!r} at T={T!r} is N = {N:.3g} samples, above the "
                f"limit of {limit:.3g} samples per run (its inputs alone would take "
                f"{16 * N / 2**30:.3g} GiB); shorten the run or raise the limit with "
                f"${MAX_SAMPLES_ENV}")
        return N

    def reference_samples(self, T: float) -> np.ndarray:
        """The reference at ``t = 0, T, ..., (N-1) T``.

        Parameters
        ----------
        T : float
            As for :meth:`n_samples`.

        Returns
        -------
        numpy.ndarray
            ``(N,)``.

        Raises
        ------
        DimensionError
            A reference array whose length is not ``N``.
        ParameterError
            A callable reference returning non-finite values.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Scenario(0.1, 0.003).reference_samples(1e-3)
        array([0.1, 0.1, 0.1])
        """
        N = self.n_samples(T)
        ref = self.reference
        t = np.arange(N) * T
        if callable(ref):
            try:
                values = np.asarray(ref(t), dtype=float)
            except (TypeError, ValueError, AttributeError):  # scalar-only: point by point
                values = None
            if values is None or values.shape != (N,):
                values = np.array([float(ref(tk)) for tk in t])
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                raise ParameterError(
                    f"reference(t) returned a non-finite value {values[bad[0]]!r} at sample "
                    f"{bad[0]} (t = {t[bad[0]]:g} s); it must be finite")
            return values
        if np.ndim(ref) == 0:
            return np.full(N, float(ref))
        arr = np.asarray(ref, dtype=float)
        if arr.shape != (N,):
            raise DimensionError(
                f"reference must be a scalar, a callable r(t) or an array of N = "
                f"round(duration/T) = {N} samples (t = 0, T, ..., (N-1)T), got shape {arr.shape}")
        return arr.copy()

    def replace(self, **changes) -> Scenario:
        """A copy with fields changed, validated again.

        Parameters
        ----------
        **changes
            New values of ``reference``, ``duration``, ``x0``, ``noise``, ``quantization``,
            ``initial_estimate``.

        Returns
        -------
        Scenario

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Scenario(0.3, 20.0).replace(duration=5.0).duration
        5.0
        """
        from ..design import replace_fields

        return replace_fields(self, changes)

    def to_dict(self) -> dict:
        """Strict-JSON fields (a callable reference by its name; ``duration`` None: adaptive).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Scenario(0.3, 20.0).to_dict()["noise"]
        {'std': 0.0, 'seed': 0}
        """
        return {"reference": jsonable(self.reference),
                "duration": None if self.duration is None else float(self.duration),
                "x0": jsonable(self.x0), "noise": self.noise.to_dict(),
                "quantization": jsonable(self.quantization),
                "disturbance": (None if self.disturbance is None
                                else self.disturbance.to_dict()),
                "initial_estimate": jsonable(self.initial_estimate)}


__all__ = ["Noise", "Scenario"]
