"""The shared validators: every bad value gets an fl_design error that names it."""

import math

import numpy as np
import pytest

from fl_design import _validate as v
from fl_design import errors


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -math.inf, "abc", None, True, [1.0]])
def test_real_scalar_rejects_non_finite_and_non_numbers(bad):
    with pytest.raises(errors.ParameterError, match="eps"):
        v.real_scalar("eps", bad)


@pytest.mark.parametrize("bad", [0.0, -1e-9, -3])
def test_positive_rejects_non_positive(bad):
    with pytest.raises(errors.ParameterError, match=r"T must be > 0"):
        v.positive("T", bad)


def test_nonnegative_accepts_zero_and_rejects_negative():
    assert v.nonnegative("ki", 0) == 0.0
    with pytest.raises(errors.ParameterError, match=r"ki must be >= 0, got -0.5"):
        v.nonnegative("ki", -0.5)


def test_integer_bounds_and_type():
    assert v.integer("rho", 3, minimum=1, maximum=6) == 3
    with pytest.raises(errors.ParameterError, match="rho must be <= 6, got 7"):
        v.integer("rho", 7, minimum=1, maximum=6)
    with pytest.raises(errors.ParameterError, match="rho must be an integer"):
        v.integer("rho", 2.0)
    with pytest.raises(errors.ParameterError, match="rho must be an integer"):
        v.integer("rho", True)


def test_real_vector_shape_length_and_finiteness():
    np.testing.assert_array_equal(v.real_vector("k", (1, 2), length=2), [1.0, 2.0])
    with pytest.raises(errors.DimensionError, match="k must have length 3, got 2"):
        v.real_vector("k", (1, 2), length=3)
    with pytest.raises(errors.DimensionError, match="one-dimensional"):
        v.real_vector("k", [[1, 2]])
    with pytest.raises(errors.ParameterError, match="finite"):
        v.real_vector("k", [1, float("nan")])


def test_interval_forms_and_reversed():
    assert v.interval("u_limits", None) is None
    assert v.interval("u_limits", 2.5) == (-2.5, 2.5)
    assert v.interval("u_limits", (-1, 3)) == (-1.0, 3.0)
    with pytest.raises(errors.ParameterError, match=r"lo < hi, got \(3.0, -1.0\)"):
        v.interval("u_limits", (3, -1))
    with pytest.raises(errors.DimensionError, match=r"\(lo, hi\)"):
        v.interval("u_limits", (1, 2, 3))


def test_hurwitz_monic_reports_bad_roots():
    roots = v.hurwitz_monic("gains", np.array([3.0, 2.0]), what="s^2+3s+2")
    np.testing.assert_allclose(np.sort(roots.real), [-2.0, -1.0])
    with pytest.raises(errors.HurwitzError, match=r"roots not in the open left half-plane: 2, 1"):
        v.hurwitz_monic("gains", np.array([-3.0, 2.0]), what="s^2-3s+2")


def test_error_classes_subclass_builtins():
    assert issubclass(errors.ParameterError, ValueError)
    assert issubclass(errors.HurwitzError, ValueError)
    assert issubclass(errors.ComputationError, RuntimeError)
    assert issubclass(errors.MissingDependencyError, RuntimeError)
    assert issubclass(errors.RelativeDegreeError, errors.FlDesignError)
