"""What backs a design for a plant class: noise gain, margins at the class's extremes, and runs
on class members (:func:`fl_design.tune` with a :class:`fl_design.PlantClass`).

* **noise gain** of the class's surrogate loop (chain of ``rho`` integrators under ZOH, ``b``
  frozen, the design's own step linearized: :class:`fl_design.analysis._surrogate.SurrogateLoop`):
  the steady-state rms of ``u`` and of ``y`` per unit rms of white sensor noise, from the
  discrete Lyapunov equation (SciPy), at each end of ``b``'s range (the larger is the class's);
* **margins** at the plant input at each end of ``b``'s range
  (:func:`fl_design.analysis.loop_margins`);
* **members**: closed-loop runs of the design on members of the class in the virtual rig
  (:mod:`fl_design.sim._rig`: the design's one step function, the class's noise and input
  delay): chains at ``b_min``, ``b_max`` and their geometric mean, ``b`` switching between its
  extremes at random dwell times and at every sample, and, when the class has a slope box for
  ``a``, the box's corners at both ends of ``b``. Every member is held at the class's operating
  point by its ``u_eq``: ``y^(rho) = a_row . (xi - xi_op) + b (u - u_eq)`` (:func:`member_rig`;
  a member with ``a = 0`` and ``u = u_eq != 0`` would drift from the start, a plant outside the
  class). Each run is a step from the operating point to the reference, as long as the loop asks
  (``12 / decay``; at most :data:`MAX_RUN` s or :data:`MAX_SAMPLES` samples, the longer); it
  converges when, over the last fifth of the run, the mean error is within
  2 % of the step plus three noise standard deviations and the largest error within 10 % of the
  step plus six.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.tuning._class_checks import surrogate_noise_gain
>>> d = fl.presets.pendulum_design()
>>> g = surrogate_noise_gain(d, 1.0)
>>> bool(g["u"] > 0 and g["y"] > 0)
True
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..analysis import loop_margins
from ..analysis._surrogate import SurrogateLoop
from ..sim._rig import Rig

#: Largest run length of a member run [s] (unless :data:`MAX_SAMPLES` samples last longer).
MAX_RUN = 60.0
#: Samples a member run may always take (60 s at T = 0.5 ms): a slow loop at a long T
#: (T = 20 ms, decay 0.025 rad/s: 480 s) is not cut at :data:`MAX_RUN` and judged unconverged.
MAX_SAMPLES = 120_000


def member_rig(rho: int, *, b, T: float, y0: float = 0.0, u_eq: float = 0.0, a_row=None,
               **kw) -> Rig:
    """A member of a class: ``y^(rho) = a_row . (y - y0, y', ...) + b (u - u_eq)``, at rest at
    ``y0`` under ``u_eq``; ``b`` a constant, or None for ``b = p`` (switching ``b``).

    Examples
    --------
    >>> import fl_design as fl
    >>> rig = member_rig(1, b=0.5, T=0.01, y0=50.0, u_eq=40.0)
    >>> d = fl.Design(estimator=fl.EHGO(rho=1, eps=0.05, T=0.01),
    ...               controller=fl.DynamicController((1.0,), 0.5))
    >>> log = rig.run(d, 50.0, 1.0, u0=40.0)
    >>> float(abs(log.y_true - 50.0).max()) < 1e-9
    True
    """
    a = np.zeros(rho) if a_row is None else np.asarray(a_row, dtype=float)
    y0, u_eq = float(y0), float(u_eq)

    def bb(x, p):
        return p if b is None else float(b)

    def ode(x, u, p):
        dev = [x[0] - y0] + [x[i] for i in range(1, rho)]
        return [x[i + 1] for i in range(rho - 1)] + [
            sum(float(a[i]) * dev[i] for i in range(rho)) + bb(x, p) * (u - u_eq)]
    what = "b=p" if b is None else f"b={float(b):g}"
    return Rig(ode=ode, x0=(y0,) + (0.0,) * (rho - 1), T=T, b=bb,
               name=kw.pop("name", f"member rho={rho}, {what}"), **kw)


def surrogate_noise_gain(design, b: float, a_row=None) -> dict:
    """rms ``u`` and rms ``y`` per unit rms white sensor noise, surrogate loop at frozen ``b``.

    Returns ``{"u": inf, "y": inf}`` when the loop is not Schur there.
    """
    loop = SurrogateLoop(design)
    M0, M1 = loop.parts(a_row=a_row)
    M = M0 + float(b) * M1
    if max(abs(np.linalg.eigvals(M))) >= 1.0:
        return {"u": math.inf, "y": math.inf}
    Js, Jy, _us, uy = loop._jacobians(None, None)
    rho = design.rho
    N = np.zeros(rho + Js.shape[0])
    N[rho:] = np.asarray(Jy).ravel()
    N = N[loop.keep]
    row = loop.input_row()[loop.keep]
    W = scipy.linalg.solve_discrete_lyapunov(M, np.outer(N, N), method="bilinear")
    u = math.sqrt(max(float(row @ W @ row) + float(uy.item()) ** 2, 0.0))
    y = math.sqrt(max(float(W[0, 0]), 0.0))
    return {"u": u, "y": y}


@dataclass(frozen=True)
class MemberRun:
    """One class member under the design: what it is and how the step went.

    Examples
    --------
    >>> MemberRun("chain b = 1", 1.0, 0.0, 0.5, 2.0, 1e-4, 3.0, True).converged
    True
    """

    member: str
    b_lo: float
    overshoot: float
    settling_time: float
    u_peak: float
    final_error: float
    b_hi: float
    converged: bool

    def to_dict(self) -> dict:
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in self.__dict__.items()}

    def line(self) -> str:
        b = f"b = {self.b_lo:.4g}" if self.b_lo == self.b_hi else \
            f"b in [{self.b_lo:.4g}, {self.b_hi:.4g}]"
        v = "converges" if self.converged else "DOES NOT CONVERGE"
        return (f"{self.member} ({b}): {v}; overshoot {self.overshoot:.3g} %, settling "
                f"{self.settling_time:.3g} s, |u| peak {self.u_peak:.3g}, final error "
                f"{self.final_error:.2g}")


def _metrics(log, r: float, y0: float, noise: float, member: str, b_lo, b_hi) -> MemberRun:
    y, u = log.y_true, log.u
    step = abs(r - y0) or 1.0
    if not np.all(np.isfinite(y)):
        return MemberRun(member, b_lo, math.inf, math.inf, math.inf, math.inf, b_hi, False)
    tail = y[int(0.8 * y.size):]
    err = float(abs(np.mean(tail) - r))
    band = 0.02 * step + 3.0 * noise
    ok = err <= band and float(np.max(np.abs(tail - r))) <= 0.1 * step + 6.0 * noise
    sgn = math.copysign(1.0, r - y0)
    over = max(0.0, float(np.max(sgn * (y - r)))) / step * 100.0
    out = np.flatnonzero(np.abs(y - r) > band)
    settle = 0.0 if out.size == 0 else float(log.t[min(out[-1] + 1, y.size - 1)])
    return MemberRun(member, float(b_lo), over, settle if ok else math.inf,
                     float(np.max(np.abs(u))), err, float(b_hi), bool(ok))


def member_runs(design, cls, r: float, duration: float, *, seed: int = 0) -> tuple:
    """Runs of ``design`` on the class's members (the module says which)."""
    rho, T = cls.rho, float(design.T)
    lo, hi = cls.b
    y0 = 0.0 if cls.operating_point is None else float(cls.operating_point)
    duration = min(max(MAX_RUN, MAX_SAMPLES * T), max(duration, 2000 * T))
    N = round(duration / T)
    u0 = 0.0 if cls.u_eq is None else float(cls.u_eq)
    kw = {"T": T, "noise_std": cls.noise_std, "delay": cls.delay, "y0": y0, "u_eq": u0}
    runs = []

    def run(name, rig, p=None, b_lo=None, b_hi=None):
        log = rig.run(design, r, duration, p=p, seed=seed, u0=u0)
        runs.append(_metrics(log, r, y0, cls.noise_std, name, b_lo, b_hi))

    for b in sorted({lo, hi, math.copysign(math.sqrt(lo * hi), lo)}):
        run(f"chain at b = {b:.4g}", member_rig(rho, b=b, **kw), b_lo=b, b_hi=b)
    rng = np.random.default_rng(seed)
    sched, k = np.empty(N), 0
    while k < N:
        n = int(rng.integers(1, 300))
        sched[k:k + n] = lo if rng.random() < 0.5 else hi
        k += n
    switch = member_rig(rho, b=None, **kw)
    run("b switching between its ends at random dwell times (1-300 samples)", switch, sched,
        lo, hi)
    run("b switching between its ends at every sample", switch,
        np.where(np.arange(N) % 2 == 0, lo, hi), lo, hi)
    if cls.a_slopes is not None:
        for corner in itertools.product(*cls.a_slopes):
            for b in (lo, hi):
                if any(corner):
                    run(f"a's slopes at the corner {tuple(round(c, 4) for c in corner)}, "
                        f"b = {b:.4g}", member_rig(rho, b=b, a_row=corner, **kw), b_lo=b, b_hi=b)
    return tuple(runs)


def class_margins(design, cls) -> tuple:
    """Loop margins at the plant input at both ends of ``b``'s range."""
    return tuple(loop_margins(design, b) for b in sorted(set(cls.b)))


__all__ = ["MAX_RUN", "MAX_SAMPLES", "MemberRun", "class_margins", "member_rig", "member_runs",
           "surrogate_noise_gain"]
