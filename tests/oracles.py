"""Independent NumPy oracles for the analysis tests (no fl_design loop code is reused).

``surrogate_loop_matrix`` builds the sampled linear surrogate loop of an EHGO design by hand:
the chain of ``rho`` integrators under exact zero-order hold (closed-form ``T^j / j!``
entries), ``sigma = b u``; the observer from the EHGO's own matrices ``(A_d, B_d)`` and
``(D^-1 C_d, D^-1 D_d)``; the controller law written out:
``z_k = z + T xhat_1``, ``v = -k_1 xhat_1 - sum k_i xhat_i - k_I z_k``,
``u_k = u + gamma (v - sigmahat)``. Loop state ``(x_1..x_rho, xi, u, z)``.
"""

from __future__ import annotations

import math

import numpy as np


def chain_zoh_closed_form(rho: int, T: float) -> tuple[np.ndarray, np.ndarray]:
    """``Phi_ij = T^(j-i)/(j-i)!`` (j >= i), ``Gamma_i = T^(rho-i+1)/(rho-i+1)!`` (1-based)."""
    Phi = np.zeros((rho, rho))
    for i in range(rho):
        for j in range(i, rho):
            Phi[i, j] = T ** (j - i) / math.factorial(j - i)
    Gam = np.array([T ** (rho - i) / math.factorial(rho - i) for i in range(rho)])
    return Phi, Gam


def surrogate_loop_matrix(ehgo, gains, gamma: float, ki: float, b: float) -> np.ndarray:
    """The ``(rho + (rho+1) + 2)``-square loop matrix of the surrogate at input gain ``b``."""
    rho, T = ehgo.rho, ehgo.T
    Ad, Bd, _, _ = ehgo.matrices
    Co, Do = ehgo.output_matrices()
    m = rho + 1
    n = rho + m + 2
    Px = np.hstack([np.eye(rho), np.zeros((rho, m + 2))])
    Pxi = np.hstack([np.zeros((m, rho)), np.eye(m), np.zeros((m, 2))])
    e1 = np.zeros((1, rho))
    e1[0, 0] = 1.0
    Y = e1 @ Px                                   # y_k = x_1
    Xh = Do.reshape(-1, 1) @ Y + Co @ Pxi         # xhat_1..xhat_rho, sigmahat
    eu, ez = np.eye(n)[rho + m], np.eye(n)[rho + m + 1]
    Z = ez + T * Xh[0]
    v = -gains[0] * Xh[0] - ki * Z
    for i in range(1, rho):
        v = v - gains[i] * Xh[i]
    U = eu + gamma * (v - Xh[rho])
    Phi, Gam = chain_zoh_closed_form(rho, T)
    return np.vstack([Phi @ Px + b * Gam[:, None] @ U[None, :],
                      Bd.reshape(-1, 1) @ Y + Ad @ Pxi, U[None, :], Z[None, :]])


def spectral_radius_over_b(ehgo, gains, gamma, ki, b_values) -> float:
    """Largest eigenvalue modulus (``numpy.linalg.eigvals``) over the given ``b`` values."""
    return max(float(np.max(np.abs(np.linalg.eigvals(
        surrogate_loop_matrix(ehgo, gains, gamma, ki, b))))) for b in b_values)
