"""Relative degree decided exactly, not against the plant's magnitudes (issue 19's false
diagnoses), with a warning only when the input's coefficient is at double round-off."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.signal
import sympy as sp

import fl_design as fl
from fl_design.errors import PoorlyScaledWarning, RelativeDegreeError

x1, x2, u = sp.symbols("x1 x2 u", real=True)


@pytest.mark.parametrize("second, b", [(-1e10 * x1 + u, 1.0), (-x1 + 1e-12 * u, 1e-12),
                                       (x1**30 + u, 1.0), (1e8 * x1**3 - 1e-9 * u, -1e-9)])
def test_badly_scaled_plants_are_actuated_without_warning(second, b):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plant = fl.Plant.from_ode([x1, x2], u, [x2, second], x1)
        nf = plant.normal_form()
    assert nf.rho == 2 and float(nf.b) == pytest.approx(b, rel=1e-12)
    A, B, C, _ = plant.linearization()  # independent: C A B is the first nonzero Markov parameter
    assert (C @ B).item() == 0 and (C @ A @ B).item() == pytest.approx(b, rel=1e-12)


def test_a_coefficient_at_round_off_is_kept_with_a_warning(tmp_path, monkeypatch):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path))
    for _ in ("derived", "read from the cache"):  # the warning is stored with the derivation
        with pytest.warns(PoorlyScaledWarning, match="coefficient 1.0+e-16.*limit of double"):
            rho = fl.Plant.from_ode([x1, x2], u, [x2, -x1 + 1e-16 * u], x1).relative_degree()
        assert rho == 2


def test_an_exact_cancellation_is_not_actuation():
    with pytest.raises(RelativeDegreeError, match="does not appear"):
        fl.Plant.from_ode([x1, x2], u, [x2, sp.sin(x1)**2 * u + sp.cos(x1)**2 * u - u - x1],
                          x1).relative_degree()


def test_a_cancellation_of_the_plants_own_floats_is_zero():
    # C B of a numerically transformed linear plant: ~1e-17 from terms of size ~1
    rng = np.random.default_rng(3)
    T = rng.normal(size=(3, 3))
    Ac, Bc, Cc, _ = scipy.signal.tf2ss([1.0], np.poly([-1.0, -2.0, -3.0]))
    A, B, C = np.linalg.solve(T, Ac @ T), np.linalg.solve(T, Bc), Cc @ T
    assert abs((C @ B).item()) < 1e-14 and abs((C @ A @ B).item()) < 1e-13
    z = sp.symbols("z0:3", real=True)
    rhs = [sum(sp.Float(A[i, j]) * z[j] for j in range(3)) + sp.Float(B[i, 0]) * u
           for i in range(3)]
    out = sum(sp.Float(C[0, j]) * z[j] for j in range(3))
    assert fl.Plant.from_ode(list(z), u, rhs, out).relative_degree() == 3
