"""Gain, phase and delay margins of the sampled surrogate loop, cut at the plant input.

The loop of :mod:`._surrogate` (chain of ``rho`` integrators under exact ZOH, ``b`` frozen,
closed by the design's own step) is cut at the plant input: ``w`` drives the plant
``x+ = Phi x + b Gamma w``, ``y = x_1``; the design step ``s+ = J_s s + J_y y`` gives
``u = U_s s + U_y y``; the loop closes with ``w = u``. In the negative-feedback convention the
open loop is ``L = -G``, ``G: w -> u``; exported as a discrete python-control ``StateSpace``
(``dt = T``) when python-control is installed.

Computed here in NumPy (python-control's ``stability_margins`` falls back to a coarse
frequency grid on these loops, whose poles lie within 1e-6 of ``z = 1``):

* **gain margins** ``(k_min, k_max)``: the run of loop gains ``k`` (``w = k u``) containing 1 on
  which ``A + k B C`` is Schur (eigenvalues; log scan, then bisection to 1e-4);
* **phase margin**: the smallest ``180 + arg L`` over the gain crossovers ``|L| = 1`` on a log
  frequency grid up to Nyquist (``L(e^(j w T))`` by a linear solve, crossovers refined by
  bisection); **delay margin**: ``phase margin / crossover frequency`` (seconds).

Examples
--------
>>> import fl_design as fl
>>> from fl_design.analysis._margins import loop_margins
>>> m = loop_margins(fl.presets.paper_design(), 3.6)
>>> bool(m.gain_margins[0] < 1 < m.gain_margins[1]), m.phase_margin > 10
(True, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._blas import serial_blas
from .._numerics import bisect_log
from ..errors import ParameterError
from ._cert_results import _Result
from ._surrogate import SurrogateLoop, chain_zoh


@dataclass(frozen=True, repr=False)
class LoopMargins(_Result):
    """Margins at the plant input of the surrogate loop at one frozen ``b``.

    Parameters
    ----------
    b : float
        The frozen ``b``.
    gain_margins : (float, float)
        ``(k_min, k_max)``: loop gains between them keep the loop Schur (NaN: not stable at 1).
    phase_margin : float
        Degrees (inf: no gain crossover).
    crossover : float
        Gain-crossover frequency of the phase margin (rad/s; NaN when none).
    delay_margin : float
        Seconds of extra delay at the plant input the loop tolerates (inf: no crossover).
    poles : numpy.ndarray
        Closed-loop poles (``z``-plane).
    statespace : object
        The open loop ``L = -G`` as a python-control ``StateSpace`` (None without
        python-control). Not in :meth:`to_dict`.

    Examples
    --------
    >>> import numpy as np
    >>> m = LoopMargins(5.0, (0.5, 9.0), 20.0, 2.0, 0.17, np.array([0.5]), None)
    >>> m.to_dict()["gain_margins"]
    [0.5, 9.0]
    """

    b: float
    gain_margins: tuple
    phase_margin: float
    crossover: float
    delay_margin: float
    poles: np.ndarray
    statespace: object

    def to_dict(self) -> dict:
        out = super().to_dict()
        del out["statespace"]
        out["poles"] = [[float(z.real), float(z.imag)] for z in np.asarray(self.poles)]
        return out

    def _repr_lines(self):
        lo, hi = self.gain_margins
        return [(f"b = {self.b:g}: loop gain in ({lo:.4g}, {hi:.4g}) keeps it stable, phase "
                 f"margin {self.phase_margin:.4g} deg at {self.crossover:.4g} rad/s, delay "
                 f"margin {self.delay_margin:.4g} s")]


def open_loop(design, b: float, eps: float | None = None, gamma: float | None = None):
    """``(A, B, C)`` of ``G: w -> u`` (the loop cut at the plant input), kept states only.

    Examples
    --------
    >>> import fl_design as fl
    >>> A, B, C = open_loop(fl.presets.paper_design(), 5.0)
    >>> A.shape, B.shape, C.shape
    ((7, 7), (7,), (7,))
    """
    loop = SurrogateLoop(design)
    rho = loop.rho
    Phi, Gam = chain_zoh(rho, loop.T)
    A, _ = loop.assemble(Phi, Gam, np.zeros(rho + design.state_size), eps, gamma)
    B = np.zeros(len(loop.keep))
    B[:rho] = float(b) * Gam
    return A, B, loop.input_row(eps, gamma)[loop.keep]


def _schur(A, B, C, k: float) -> bool:
    return bool(np.max(np.abs(np.linalg.eigvals(A + k * np.outer(B, C)))) < 1.0)


def _gain_margins(A, B, C) -> tuple:
    if not _schur(A, B, C, 1.0):
        return (math.nan, math.nan)
    hi = 1.0
    while hi < 1e6 and _schur(A, B, C, 2.0 * hi):
        hi *= 2.0
    k_max = math.inf if hi >= 1e6 else bisect_log(lambda k: _schur(A, B, C, k), hi, 2.0 * hi,
                                                   rtol=1e-4).lo
    lo = 1.0
    while lo > 1e-6 and _schur(A, B, C, lo / 2.0):
        lo /= 2.0
    k_min = 0.0 if lo <= 1e-6 else 1.0 / bisect_log(lambda x: _schur(A, B, C, 1.0 / x),
                                                     1.0 / lo, 2.0 / lo, rtol=1e-4).lo
    return (float(k_min), float(k_max))


def loop_margins(design, b: float, *, eps: float | None = None, gamma: float | None = None,
                 n_freq: int = 4000, statespace: bool = True) -> LoopMargins:
    """Gain, phase and delay margins at the plant input, ``b`` frozen.

    Parameters
    ----------
    design : Design
        An EHGO design (its ``eps`` and ``gamma`` unless given).
    b : float
        The input coefficient (nonzero; the loop uses ``|b|`` and ``|gamma|``).
    eps, gamma : float, optional
        Other numbers than the design's.
    n_freq : int, optional
        Points of the log frequency grid (default 4000).
    statespace : bool, optional
        Build the python-control ``StateSpace`` of the open loop (its import takes about a
        second the first time); False: ``statespace`` is None, every number the same.

    Returns
    -------
    LoopMargins

    Raises
    ------
    ParameterError
        ``b`` zero or not finite.

    Examples
    --------
    >>> import fl_design as fl
    >>> m = loop_margins(fl.presets.paper_design(), 6.8)
    >>> bool(np.all(np.abs(m.poles) < 1)), round(m.gain_margins[1], 1)
    (True, 9.1)
    """
    b = float(b)
    if not math.isfinite(b) or b == 0.0:
        raise ParameterError(f"b must be a finite nonzero number, got {b!r}")
    g = abs(design.controller.gamma) if gamma is None else abs(float(gamma))
    A, B, C = open_loop(design, abs(b), eps, g)
    T, eye = design.T, np.eye(A.shape[0])

    def L(w):
        return complex(-(C @ np.linalg.solve(np.exp(1j * w * T) * eye - A, B)))

    with serial_blas():  # 4000 small solves and the bisections: one OpenBLAS thread
        return _margins(b, A, B, C, L, T, eye, n_freq, statespace)


def _margins(b, A, B, C, L, T, eye, n_freq, statespace) -> LoopMargins:
    """:func:`loop_margins` after the open loop is built (its docstring)."""
    w = np.geomspace(1e-6 / T, math.pi / T, int(n_freq))
    # the grid's L(w) in one stacked solve (the same LAPACK solve per point as L)
    Xs = np.linalg.solve(np.exp(1j * w * T)[:, None, None] * eye - A, B.astype(complex)[:, None])
    mag = np.array([abs(complex(-(C @ x))) for x in Xs[..., 0]]) - 1.0
    pm, wc = math.inf, math.nan
    for i in np.flatnonzero(np.sign(mag[:-1]) != np.sign(mag[1:])):
        above = mag[i] > 0.0
        br = bisect_log(lambda x, a=above: (abs(L(x)) > 1.0) == a, w[i], w[i + 1], rtol=1e-9)
        x = math.sqrt(br.lo * br.hi)
        margin = (180.0 + math.degrees(np.angle(L(x))) + 180.0) % 360.0 - 180.0
        if abs(margin) < abs(pm):
            pm, wc = margin, x
    delay = math.radians(pm) / wc if math.isfinite(wc) else math.inf
    ss = None
    if statespace:
        try:
            import control

            ss = control.ss(A, B[:, None], -C[None, :], np.zeros((1, 1)), dt=T)
        except ImportError:
            pass
    return LoopMargins(b, _gain_margins(A, B, C), float(pm), float(wc), float(delay),
                       np.linalg.eigvals(A + np.outer(B, C)), ss)


__all__ = ["LoopMargins", "loop_margins", "open_loop"]
