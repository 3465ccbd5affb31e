"""The EHGO's delta realization: same input-output map, zero DC gain to the derivatives."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as sig

import fl_design as fl
from fl_design.design import METHODS


@pytest.mark.parametrize("method", list(METHODS))
@pytest.mark.parametrize("rho,eps", [(1, 0.05), (2, 0.05), (3, 0.01), (5, 0.02)])
def test_delta_has_the_input_output_map_of_the_direct_matrices(method, rho, eps):
    obs = fl.EHGO(rho, eps, 1e-3, method=method, allow_unstable=True)
    delta = obs.replace(realization="delta")
    y = np.sin(np.arange(1500) * 3e-3) + 1e-2 * np.random.default_rng(rho).standard_normal(1500)
    C, D = obs.output_matrices()  # independent reference: scipy's dlsim of (A_d, B_d, C, D)
    _, ref, _ = sig.dlsim((obs.matrices.A, obs.matrices.B, C, D, obs.T), y)
    ctrl = fl.DynamicController(fl.gains_from_poles([-1.0] * rho), 1e-3)
    xhat = fl.Design(estimator=delta, controller=ctrl).run(y).xhat
    scale = np.max(np.abs(ref), axis=0)
    np.testing.assert_allclose(xhat / scale, ref / scale, rtol=0, atol=1e-9)
    np.testing.assert_allclose(delta.delta_matrix, obs.matrices.A - np.eye(rho + 1),
                               rtol=0, atol=1e-12)


def _dc_derivatives(design, n):
    return np.abs(design.run(np.ones(n)).xhat[-1, 1:])


@pytest.mark.parametrize("rho,ratio", [(3, 1.0), (4, 1.0), (5, 1.0), (5, 2.0)])
def test_constant_output_gives_zero_derivatives_in_the_delta_form(rho, ratio):
    T = 1e-3
    obs = fl.EHGO(rho, ratio * T, T)
    ctrl = fl.DynamicController(fl.gains_from_poles([-1.0] * rho), 1e-3)
    direct = fl.Design(estimator=obs, controller=ctrl)
    delta = fl.Design(estimator=obs.replace(realization="delta"), controller=ctrl)
    n = 4000
    # the direct realization's DC error, from its own matrices (NumPy), grows with 1/eps^rho
    A, B, _, _ = obs.matrices
    C, D = obs.output_matrices()
    dc_direct = C @ np.linalg.solve(np.eye(rho + 1) - A, B) + D
    assert np.max(np.abs(dc_direct[1:, 0])) > 1e-12
    assert np.max(_dc_derivatives(direct, n)) > 1e-12
    assert np.max(_dc_derivatives(delta, n)) < 1e-100  # decays to underflow: exactly zero DC


def test_delta_costs_fewer_operations_and_rejects_unknown_realization():
    obs = fl.EHGO(2, 0.05, 1e-3)
    assert obs.replace(realization="delta").flops_per_step < obs.flops_per_step
    with pytest.raises(fl.errors.ParameterError, match="realization='fast'.*'direct', 'delta'"):
        obs.replace(realization="fast")
