"""The SOS eps* search (Newton steps on the margin) against a bisection of the verdict."""

from __future__ import annotations

import pytest

from fl_design.analysis._search import certified_eps_star
from fl_design.analysis._sos_search import sos_eps_star


def _margin(kind: str, root: float):
    """``eps -> (certified, eta, slope)``: margins shaped as the SOS program's (linear,
    quadratic tangency at the root, a kink where another constraint becomes active); ``eta``
    sits at -1e-7 where nothing is certified, as the program's does."""
    def f(e):
        d = root - e
        if kind == "linear":
            eta, slope = d, -1.0
        elif kind == "quadratic":
            eta, slope = d * abs(d) * 50.0, -100.0 * abs(d)
        else:  # kinked: a shallow slope far away, a steep one near the root
            eta, slope = (d * 2.0, -2.0) if d < 0.01 else (0.02 + 0.1 * (d - 0.01), -0.1)
        ok = eta > 0.0
        return ok, (eta if ok else -1e-7), slope
    return f


@pytest.mark.parametrize("kind", ["linear", "quadratic", "kinked"])
@pytest.mark.parametrize("root", [0.05, 0.0805, 0.1173, 0.1209])
def test_search_matches_bisection_within_rtol_and_is_sound(kind, root):
    rtol, base, top = 1e-2, 0.07, 0.1214
    f = _margin(kind, root)
    calls = []

    def solve(e):
        calls.append(e)
        return f(e)

    eps, n = sos_eps_star(solve, base, top, rtol, budget=8)
    ref = certified_eps_star(lambda e: f(e)[0], base, top, rtol)
    assert n == len(calls) <= 8
    if ref is None:
        assert eps is None
        return
    assert eps is not None and f(eps)[0]  # the answer is a certified eps
    assert abs(eps / ref - 1.0) <= rtol  # the bisection's answer, to its resolution
    assert eps <= root and root / eps - 1.0 <= rtol * 1.0001  # the bracket holds the root


def test_search_needs_fewer_programs_than_bisection_on_a_linear_margin():
    f = _margin("linear", 0.1173)
    n_bis = [0]

    def pred(e):
        n_bis[0] += 1
        return f(e)[0]

    certified_eps_star(pred, 0.08, 0.1214, 1e-2)
    _, n = sos_eps_star(f, 0.08, 0.1214, 1e-2)
    assert n < n_bis[0]


def test_budget_is_respected_and_keeps_the_last_certified_eps():
    f = _margin("quadratic", 0.1173)
    eps, n = sos_eps_star(f, 0.08, 0.1214, 1e-4, budget=3)
    assert n == 3 and eps is not None and f(eps)[0] and eps < 0.1173
    assert sos_eps_star(lambda e: (False, None, None), 0.08, 0.1214, 1e-2, budget=2) == (None, 2)
