"""Disturbances of a scenario: at the plant's input and at its measured output.

The method's selling point is that the observer estimates the unknown ``sigma = a + b u``, so
the loop rejects what the model does not know. A :class:`Disturbance` says what acts on the
loop besides the reference and the sensor noise:

* ``input``: added to the controller's ``u`` at the plant, held over each sample like ``u``
  (``x' = f(x, u_k + d_k)`` on ``[kT, (k+1)T)``; exact for steps, a sampled-and-held
  approximation of faster signals);
* ``output``: added to ``y`` before the estimator (with the noise, before quantization).

Each is a :class:`Step`, a :class:`Sine`, an array of one value per sample, or a function of
time (a Python callable taking the array of sample times ``t_k = kT``, or a
``casadi.Function`` of one scalar). Both are sampled once, before the run, into the per-sample
inputs of the loop: the compiled kernel, the interpreter and the ``cvodes`` reference see the
same numbers, and a sweep's runs all see the same disturbance.

:func:`disturbance_metrics` measures the response to it: the peak deviation of ``y`` from the
reference after the disturbance starts, and the recovery time (from that start until ``|y - r|``
stays within the run's tolerance band).

Examples
--------
>>> import fl_design as fl
>>> d = fl.Disturbance(input=fl.Step(at=1.0, size=0.5))
>>> d_in, d_out = d.sampled(T=0.5, N=4)
>>> d_in.tolist(), d_out.tolist()
([0.0, 0.0, 0.5, 0.5], [0.0, 0.0, 0.0, 0.0])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import DimensionError, ParameterError


@dataclass(frozen=True)
class Step:
    """A step of ``size`` from time ``at`` on (zero before).

    Parameters
    ----------
    at : float
        Time of the step in seconds (>= 0).
    size : float
        Height of the step (in the units of ``u`` or ``y``).

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> fl.Step(at=0.2, size=2.0).values(np.array([0.0, 0.2, 0.4])).tolist()
    [0.0, 2.0, 2.0]
    """

    at: float
    size: float

    def __post_init__(self) -> None:
        V.nonnegative("Step.at", self.at)
        V.real_scalar("Step.size", self.size)

    def values(self, t: np.ndarray) -> np.ndarray:
        """The signal at the times ``t``."""
        return np.where(t >= float(self.at) - 1e-12, float(self.size), 0.0)

    def to_dict(self) -> dict:
        """Strict-JSON fields."""
        return {"kind": "step", "at": float(self.at), "size": float(self.size)}


@dataclass(frozen=True)
class Sine:
    """``amplitude * sin(2 pi frequency t + phase)`` from time ``at`` on.

    Parameters
    ----------
    amplitude : float
        Amplitude.
    frequency : float
        Frequency in Hz (> 0).
    phase : float, optional
        Phase in rad at ``t = at`` (default 0).
    at : float, optional
        Start time in seconds (default 0).

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> np.round(fl.Sine(amplitude=1.0, frequency=0.25).values(np.array([0.0, 1.0])), 12).tolist()
    [0.0, 1.0]
    """

    amplitude: float
    frequency: float
    phase: float = 0.0
    at: float = 0.0

    def __post_init__(self) -> None:
        V.real_scalar("Sine.amplitude", self.amplitude)
        V.positive("Sine.frequency", self.frequency)
        V.real_scalar("Sine.phase", self.phase)
        V.nonnegative("Sine.at", self.at)

    def values(self, t: np.ndarray) -> np.ndarray:
        """The signal at the times ``t``."""
        s = float(self.amplitude) * np.sin(2 * np.pi * float(self.frequency)
                                           * (t - float(self.at)) + float(self.phase))
        return np.where(t >= float(self.at) - 1e-12, s, 0.0)

    def to_dict(self) -> dict:
        """Strict-JSON fields."""
        return {"kind": "sine", "amplitude": float(self.amplitude),
                "frequency": float(self.frequency), "phase": float(self.phase),
                "at": float(self.at)}


def _signal(name: str, value, T: float, N: int) -> np.ndarray:
    """``(N,)`` samples of one disturbance signal (see :class:`Disturbance`)."""
    t = np.arange(N) * T
    if value is None:
        return np.zeros(N)
    if isinstance(value, (Step, Sine)):
        return value.values(t)
    if _is_casadi_function(value):
        if value.n_in() != 1 or value.numel_in(0) != 1 or value.numel_out(0) != 1:
            raise ParameterError(f"disturbance {name}: a casadi.Function must map one scalar "
                                 f"t to one scalar, got {value}")
        out = np.asarray(value.map(N)(t.reshape(1, -1)), dtype=float).ravel()
    elif callable(value):
        try:
            out = np.asarray(value(t), dtype=float)
        except Exception as exc:  # noqa: BLE001 - the user's function: say which, and why
            raise ParameterError(f"disturbance {name}: the function {value!r} failed on the "
                                 f"array of sample times ({type(exc).__name__}: {exc}); it "
                                 "must take a NumPy array of times and return one value per "
                                 "time") from None
        if out.shape != (N,):
            out = np.broadcast_to(out, (N,)).copy() if out.ndim == 0 else out
        if out.shape != (N,):
            raise DimensionError(f"disturbance {name}: the function returned shape "
                                 f"{out.shape} for {N} sample times; return one value per time")
    else:
        try:
            out = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ParameterError(f"disturbance {name} must be fl.Step, fl.Sine, an array of "
                                 f"samples or a function of t, got {value!r}") from None
        if out.ndim != 1 or out.size < N:
            raise DimensionError(f"disturbance {name}: an array needs one value per sample "
                                 f"(at least {N}), got shape {out.shape}")
        out = out[:N]
    if not np.all(np.isfinite(out)):
        raise ParameterError(f"disturbance {name} has non-finite values (first at sample "
                             f"{int(np.flatnonzero(~np.isfinite(out))[0])})")
    return out.astype(float)


def _is_casadi_function(value) -> bool:
    try:
        import casadi as ca
    except ImportError:  # pragma: no cover - a dependency
        return False
    return isinstance(value, ca.Function)


@dataclass(frozen=True)
class Disturbance:
    """What acts on the loop besides the reference and the sensor noise.

    Parameters
    ----------
    input : Step, Sine, array_like or callable, optional
        Added to ``u`` at the plant (held over each sample).
    output : Step, Sine, array_like or callable, optional
        Added to ``y`` before the estimator.

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.Disturbance(output=fl.Sine(amplitude=0.01, frequency=5.0)).to_dict()["output"]["kind"]
    'sine'
    """

    input: Any = None
    output: Any = None

    def __post_init__(self) -> None:
        for name in ("input", "output"):  # a bad value is refused now, not mid-sweep
            value = getattr(self, name)
            if isinstance(value, (list, tuple, np.ndarray)):
                _signal(name, value, 1.0, np.shape(value)[0] if np.ndim(value) else 1)
            elif value is not None and not (isinstance(value, (Step, Sine)) or callable(value)):
                raise ParameterError(f"Disturbance({name}=...) must be fl.Step, fl.Sine, an "
                                     f"array of samples or a function of t, got {value!r}")

    def sampled(self, T: float, N: int) -> tuple[np.ndarray, np.ndarray]:
        """``(d_in, d_out)``: ``(N,)`` samples at ``t_k = k T``.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Disturbance().sampled(0.1, 2)[0].tolist()
        [0.0, 0.0]
        """
        return _signal("input", self.input, T, N), _signal("output", self.output, T, N)

    def start(self, T: float, N: int) -> float:
        """Time at which the first non-zero disturbance acts (``inf``: none).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Disturbance(input=fl.Step(at=2.0, size=1.0)).start(0.01, 1000)
        2.0
        """
        return onset(*self.sampled(T, N), T)

    def to_dict(self) -> dict:
        """Strict-JSON fields (arrays and functions are named, not listed).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Disturbance().to_dict()
        {'input': None, 'output': None}
        """
        def one(v):
            if v is None or isinstance(v, (Step, Sine)):
                return None if v is None else v.to_dict()
            if callable(v):
                return {"kind": "function", "name": getattr(v, "__name__", repr(v))[:80]}
            return {"kind": "samples", "n": int(np.size(v))}

        return {"input": one(self.input), "output": one(self.output)}


def onset(d_in: np.ndarray, d_out: np.ndarray, T: float) -> float:
    """Time of the first sample at which either sampled disturbance is non-zero (``inf``: none).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._disturbance import onset
    >>> onset(np.array([0.0, 0.0, 1.0]), np.zeros(3), 0.5)
    1.0
    """
    nz = np.flatnonzero((d_in != 0) | (d_out != 0))
    return float(nz[0] * T) if nz.size else math.inf


def disturbance_metrics(t: np.ndarray, y: np.ndarray, r: np.ndarray, start: float,
                        tol: float) -> dict:
    """Peak deviation after the disturbance starts, and the time to recover.

    Parameters
    ----------
    t, y, r : numpy.ndarray
        Sample times, output and reference of a run.
    start : float
        When the disturbance starts (``inf``: none).
    tol : float
        The run's tolerance band on ``|y - r|``.

    Returns
    -------
    dict
        ``disturbance_at`` (s), ``disturbance_peak`` (max ``|y - r|`` from then on),
        ``recovery_time`` (s from ``start`` until ``|y - r| <= tol`` for good; ``inf`` when
        it never settles back within the run, NaN without a disturbance or after divergence).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._disturbance import disturbance_metrics
    >>> t = np.arange(6) * 1.0
    >>> m = disturbance_metrics(t, np.array([0, 0, .5, .2, 0, 0.]), np.zeros(6), 2.0, 0.1)
    >>> m["disturbance_peak"], m["recovery_time"]
    (0.5, 2.0)
    """
    nan = {"disturbance_at": start if math.isfinite(start) else math.nan,
           "disturbance_peak": math.nan, "recovery_time": math.nan}
    if not math.isfinite(start):
        return nan
    after = t >= start - 1e-12
    e = np.abs(np.asarray(y, dtype=float) - np.asarray(r, dtype=float))[after]
    if e.size == 0 or not np.all(np.isfinite(e)):
        return nan
    outside = np.flatnonzero(e > tol)
    if outside.size == 0:
        recovery = 0.0
    elif outside[-1] == e.size - 1:
        recovery = math.inf
    else:
        recovery = float(t[after][outside[-1] + 1] - start)
    return {"disturbance_at": float(start), "disturbance_peak": float(e.max()),
            "recovery_time": recovery}


def summary_metrics(summary: dict, T: float, start: float) -> dict:
    """:func:`disturbance_metrics` from a kernel's running accumulators (sweeps, Monte Carlo).

    ``dist_peak`` is the largest ``|y - r|`` from the disturbance's first sample on,
    ``k_dist_out`` the last such sample outside the run's band (:data:`fl_design.sim._metrics.
    ACCUMULATORS`); the same definitions as from a recorded trajectory.

    Parameters
    ----------
    summary : dict
        Accumulators (arrays of any shape), with ``N``, ``diverged``.
    T : float
        Sampling time.
    start : float
        When the disturbance starts (``inf``: none).

    Returns
    -------
    dict
        ``disturbance_peak`` and ``recovery_time`` arrays (NaN for diverged runs or without
        a disturbance; ``recovery_time`` ``inf`` when still outside the band at the end).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._disturbance import summary_metrics
    >>> m = summary_metrics({"dist_peak": np.array([0.5]), "k_dist_out": np.array([3.0]),
    ...                      "N": np.array([6.0]), "diverged": np.array([0.0])}, 1.0, 2.0)
    >>> m["disturbance_peak"].tolist(), m["recovery_time"].tolist()
    ([0.5], [2.0])
    """
    g = {k: np.asarray(summary[k], dtype=float) for k in ("dist_peak", "k_dist_out", "N",
                                                            "diverged")}
    bad = (g["diverged"] != 0) | ~np.isfinite(g["dist_peak"]) | (not math.isfinite(start))
    recovery = np.where(g["k_dist_out"] < 0, 0.0,
                        np.where(g["k_dist_out"] >= g["N"] - 1, np.inf,
                                 (g["k_dist_out"] + 1) * T - (start if math.isfinite(start)
                                                              else 0.0)))
    return {"disturbance_peak": np.where(bad, np.nan, g["dist_peak"]),
            "recovery_time": np.where(bad, np.nan, recovery)}


__all__ = ["Disturbance", "Sine", "Step", "disturbance_metrics", "onset", "summary_metrics"]
