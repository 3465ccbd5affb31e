"""Sensor noise from a log: its standard deviation and spectrum from the output's high-frequency
residual.

* **std**: the ``(rho+1)``-th difference of ``y`` removes the sampled plant's smooth response
  (its own part is ``O(T^rho |b| |du|)``), leaving ``sum_j C(k, j) (-1)^j n_(k-j)``, of
  variance ``C(2k, k) sigma^2`` for white noise; ``sigma`` is its median absolute deviation
  (robust to the input's jumps) times 1.4826, over ``sqrt(C(2k, k))``. Quantization adds
  ``q^2 / 12`` and is reported with it;
* **spectrum**: Welch's estimate of the residual of a local polynomial fit (Savitzky-Golay,
  degree ``rho + 1``, 51 samples); ``whiteness`` is the ratio of its mean level in the upper to
  the lower half of the band above the fit's cut-off (1 for white noise).

Examples
--------
>>> import numpy as np
>>> from fl_design.identification._noise import noise_std
>>> y = np.sin(np.arange(20000) * 1e-3) + 1e-3 * np.random.default_rng(0).standard_normal(20000)
>>> round(noise_std(y, 2, ((0, 20000),)) * 1e3, 2)
1.0
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal


def noise_std(y: np.ndarray, rho: int, segments) -> float:
    """Robust standard deviation of the white sensor noise (module)."""
    k = rho + 1
    d = np.concatenate([np.diff(y[a:b], n=k) for a, b in segments if b - a > k + 1])
    mad = float(np.median(np.abs(d - np.median(d))))
    return 1.4826 * mad / math.sqrt(math.comb(2 * k, k))


def noise_spectrum(y: np.ndarray, rho: int, T: float, segments) -> dict:
    """Welch spectrum of the high-frequency residual and a whiteness ratio (module)."""
    win = 51
    res = []
    for a, b in segments:
        if b - a > 4 * win:
            seg = y[a:b]
            res.append(seg - scipy.signal.savgol_filter(seg, win, rho + 1))
    if not res:
        return {"f": [], "psd": [], "whiteness": math.nan, "residual_std": math.nan}
    r = np.concatenate(res)
    f, p = scipy.signal.welch(r, fs=1.0 / T, nperseg=min(1024, r.size))
    band = f > 0.1 / T  # above the fit's cut-off (about win/ (2 pi) samples)
    fb, pb = f[band], p[band]
    half = fb.size // 2
    white = float(np.mean(pb[half:]) / np.mean(pb[:half])) if half > 1 else math.nan
    return {"f": f, "psd": p, "whiteness": white, "residual_std": float(np.std(r))}


__all__ = ["noise_spectrum", "noise_std"]
