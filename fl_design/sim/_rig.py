"""A virtual rig: a plant under any sampled controller, with noise, quantization and delay, logged.

The rig is what a test (or a user without hardware) puts where the hardware would be: a plant
``x' = f(x, u, p)`` (CasADi expressions; ``p`` a per-sample exogenous parameter such as a
switching ``b``), integrated by fixed-step RK4 over each sample with the input held (ZOH); the
measurement ``y_m = q floor((h(x) + n) / q + 1/2)`` (white Gaussian noise ``n``, optional
quantization step ``q``); the controller's input reaching the plant ``delay`` samples late. The
controller is any object with a CasADi ``step(state, y, r) -> (state_next, u)`` and
``initial_state(y0=..., u0=...)``: :class:`fl_design.Design` (its one step function, never
re-implemented) or the linear ADRC baseline (:class:`fl_design.design.LinearADRC`).

One sample of the whole loop is one CasADi function, mapped over the run (``mapaccum``): a 60 s
log at 1 kHz takes about a second. The log's columns are those a firmware writes (``t, y, u,
r``: ``u`` is what the controller commanded, ``y`` what it measured) plus the truth a test
checks against (``y_true``, and ``b_true``, the plant's ``d y^(rho) / du`` along the run when
the rig knows it).

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim._rig import Rig, chain_rig
>>> rig = chain_rig(2, b=4.0, T=1e-3, noise_std=1e-3)
>>> log = rig.run(fl.presets.pendulum_design().replace(eps=0.01), 0.1, 2.0, seed=1)
>>> sorted(log.columns())[:4], log.t.size
(['b_true', 'r', 't', 'u'], 2000)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _validate as V
from ..errors import ParameterError


@dataclass(frozen=True)
class RigLog:
    """What a run of the rig wrote: the firmware's columns and the truth.

    Parameters
    ----------
    t, y, u, r : numpy.ndarray
        Time [s], measured output, commanded input, reference.
    y_true : numpy.ndarray
        The plant's output without noise or quantization.
    b_true : numpy.ndarray
        ``d y^(rho) / du`` of the plant at each sample (NaN when the rig does not know it).
    name : str
        The rig's name.

    Examples
    --------
    >>> import numpy as np
    >>> z = np.zeros(3)
    >>> RigLog(z, z, z, z, z, z, "x").columns()["t"].size
    3
    """

    t: np.ndarray
    y: np.ndarray
    u: np.ndarray
    r: np.ndarray
    y_true: np.ndarray
    b_true: np.ndarray
    name: str = ""

    def columns(self) -> dict:
        """The log as a mapping of column arrays (what :func:`fl_design.identify` reads)."""
        return {"t": self.t, "y": self.y, "u": self.u, "r": self.r, "y_true": self.y_true,
                "b_true": self.b_true}

    def write_csv(self, path, *, truth: bool = False) -> Path:
        """Write ``t, y, u, r`` (and the truth columns if asked) as CSV with a header.

        Examples
        --------
        >>> import numpy as np, tempfile, pathlib
        >>> z = np.arange(3.0)
        >>> p = RigLog(z, z, z, z, z, z).write_csv(pathlib.Path(tempfile.mkdtemp()) / "a.csv")
        >>> p.read_text().splitlines()[0]
        't,y,u,r'
        """
        cols = ["t", "y", "u", "r"] + (["y_true", "b_true"] if truth else [])
        data = np.column_stack([self.columns()[c] for c in cols])
        path = Path(path)
        np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.10g")
        return path

    @property
    def b_range(self) -> tuple[float, float]:
        """The true ``b`` range over the visited states (``min, max`` of ``b_true``)."""
        b = self.b_true[np.isfinite(self.b_true)]
        return (float(b.min()), float(b.max())) if b.size else (math.nan, math.nan)


@dataclass(frozen=True)
class Rig:
    """A plant with its sensor and actuator path (see the module).

    Parameters
    ----------
    ode : callable
        ``ode(x, u, p) -> x'`` with CasADi operations (``casadi.sin``, ...), ``x`` a column of
        ``n`` states, ``p`` a scalar per-sample parameter.
    x0 : sequence of float
        Initial state.
    T : float
        Sampling time [s].
    output : callable, optional
        ``y = output(x)`` (default ``x[0]``).
    b : callable, optional
        ``b(x, p)``: the plant's ``d y^(rho) / du`` (logged as ``b_true``).
    noise_std : float, optional
        Sensor noise standard deviation.
    quantization : float, optional
        Sensor quantization step (None: none).
    delay : int, optional
        Input delay in samples.
    substeps : int, optional
        RK4 steps per sample.
    name : str, optional
    """

    ode: Callable
    x0: tuple
    T: float
    output: Callable | None = None
    b: Callable | None = None
    noise_std: float = 0.0
    quantization: float | None = None
    delay: int = 0
    substeps: int = 4
    name: str = "rig"
    _cache: dict = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self):
        V.positive("T", self.T)
        V.nonnegative("noise_std", self.noise_std)
        if self.quantization is not None:
            V.positive("quantization", self.quantization)
        V.integer("delay", self.delay, minimum=0, maximum=10000)
        V.integer("substeps", self.substeps, minimum=1, maximum=1000)
        object.__setattr__(self, "x0", tuple(float(v) for v in self.x0))

    def _loop(self, controller):
        import casadi as ca

        key = id(controller.step)
        if key in self._cache:
            return self._cache[key][1]
        n, d = len(self.x0), int(self.delay)
        m = int(np.asarray(controller.initial_state(y0=0.0)).size)
        X = ca.SX.sym("X", n + m + d)
        w, r, p, e = ca.SX.sym("w"), ca.SX.sym("r"), ca.SX.sym("p"), ca.SX.sym("e")
        x, s, buf = X[:n], X[n:n + m], X[n + m:]
        h = (lambda v: v[0]) if self.output is None else self.output
        y_true = h(x)
        y = y_true + w
        if self.quantization is not None:
            q = float(self.quantization)
            y = q * ca.floor(y / q + 0.5)
        s_next, u_c = controller.step(s, y, r)
        u = u_c + e  # the excitation added to the controller's input: what is applied
        u_plant = buf[d - 1] if d else u
        buf_next = (ca.vertcat(u, buf[:d - 1]) if d > 1 else u) if d else ca.SX(0, 1)
        dt = self.T / self.substeps

        def f(v):
            res = self.ode(v, u_plant, p)
            return ca.vertcat(*[res[i] for i in range(n)])
        xn = x
        for _ in range(self.substeps):
            k1 = f(xn)
            k2 = f(xn + dt / 2 * k1)
            k3 = f(xn + dt / 2 * k2)
            k4 = f(xn + dt * k3)
            xn = xn + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        b = self.b(x, p) if self.b is not None else ca.SX(math.nan)
        F = ca.Function("rig_step", [X, w, r, p, e],
                        [ca.vertcat(xn, s_next, buf_next), ca.vertcat(y, u, y_true, b)])
        # keep the controller alive with its step: the cache key is its step's id
        self._cache[key] = (controller, F)
        return F

    def run(self, controller, reference, duration: float, *, p=None, seed: int = 0,
            u0: float = 0.0, excitation=None) -> RigLog:
        """Run the closed loop and return its log.

        Parameters
        ----------
        controller : Design or LinearADRC
            Anything with ``step`` and ``initial_state``; its ``T`` should be the rig's.
        reference : float, callable or array_like
            ``r`` (constant, ``r(t)``, or samples).
        duration : float
            Seconds.
        p : float, callable or array_like, optional
            The plant's exogenous parameter per sample (default 0).
        seed : int, optional
            Noise seed.
        u0 : float, optional
            The controller's initial input (bumpless start at the first measurement).
        excitation : float, callable or array_like, optional
            A signal added to the controller's input (an identification experiment: a square
            wave, a PRBS); the log's ``u`` is the sum, what was applied.

        Returns
        -------
        RigLog

        Raises
        ------
        ParameterError
            A non-positive duration, a controller sampled at another ``T``.
        """
        V.positive("duration", duration)
        T = float(self.T)
        if not math.isclose(float(getattr(controller, "T", T)), T, rel_tol=1e-9):
            raise ParameterError(f"the controller samples at T = {controller.T:g} s, the rig at "
                                 f"T = {T:g} s: use one sampling time")
        N = round(duration / T)
        t = np.arange(N) * T
        r = _samples("reference", reference, t)
        pk = _samples("p", 0.0 if p is None else p, t)
        ek = _samples("excitation", 0.0 if excitation is None else excitation, t)
        w = float(self.noise_std) * np.random.default_rng(int(seed)).standard_normal(N)
        F = self._loop(controller)
        y0 = float(((lambda v: v[0]) if self.output is None else self.output)(
            np.asarray(self.x0)))
        s0 = np.asarray(controller.initial_state(y0=y0, u0=u0), dtype=float).ravel()
        X0 = np.concatenate([self.x0, s0, np.full(self.delay, float(u0))])
        _, out = F.mapaccum("rig_run", N)(X0, w[None, :], r[None, :], pk[None, :],
                                                   ek[None, :])
        out = np.asarray(out, dtype=float)
        with np.errstate(invalid="ignore"):
            bad = ~np.all(np.isfinite(out[:3]), axis=0)
        if bad.any():  # diverged: NaN from there on (the truth says what happened)
            out[:, int(np.argmax(bad)):] = np.nan
        return RigLog(t, out[0], out[1], r, out[2], out[3], self.name)


def _samples(name, value, t):
    if callable(value):
        return np.asarray([float(value(x)) for x in t], dtype=float)
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return np.full(t.size, float(arr))
    if arr.shape != t.shape:
        raise ParameterError(f"{name} has {arr.size} samples, the run {t.size}")
    return arr


def chain_rig(rho: int, *, b=1.0, T: float, a_row=None, **kw) -> Rig:
    """The chain ``y^(rho) = a_row . (y, ..., y^(rho-1)) + b u``; ``b`` a constant, or None
    for ``b = p`` (the per-sample parameter: switching ``b``).

    Examples
    --------
    >>> chain_rig(2, b=None, T=1e-3).name
    'chain rho=2, b=p'
    """
    rho = V.integer("rho", rho, minimum=1, maximum=8)
    a = np.zeros(rho) if a_row is None else np.asarray(a_row, dtype=float)

    def bb(x, p):
        return p if b is None else float(b)

    def ode(x, u, p):
        top = [x[i + 1] for i in range(rho - 1)]
        return top + [sum(float(a[i]) * x[i] for i in range(rho)) + bb(x, p) * u]
    what = "b=p" if b is None else f"b={float(b):g}"
    kw.setdefault("name", f"chain rho={rho}, {what}")
    return Rig(ode=ode, x0=kw.pop("x0", (0.0,) * rho), T=T, b=bb, **kw)


__all__ = ["Rig", "RigLog", "chain_rig"]
