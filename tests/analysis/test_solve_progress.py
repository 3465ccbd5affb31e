"""solve_progress: a caller's progress line during a long certificate (issue 33)."""

import cvxpy as cp

from fl_design.analysis._lmi import solve_count, solve_progress, solve_quietly


def _solve_one() -> None:
    x = cp.Variable()
    assert solve_quietly(cp.Problem(cp.Minimize(x), [x >= 1])) is None
    assert abs(float(x.value) - 1.0) < 1e-6  # an answer, not just a call


def test_solve_progress_calls_back_per_solve_throttled_and_restores_the_outer_listener():
    outer, inner = [], []
    n0 = solve_count()
    with solve_progress(lambda: outer.append(solve_count()), every=0.0):
        _solve_one()
        with solve_progress(lambda: inner.append(solve_count()), every=3600.0):
            _solve_one()
            _solve_one()
        _solve_one()
    _solve_one()  # outside: nobody called
    assert solve_count() - n0 == 5
    assert outer == [n0 + 1, n0 + 4]  # the inner block replaced it, then gave it back
    assert inner == []  # within the hour of its start: throttled
