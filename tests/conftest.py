"""Shared fixtures: the pendulum test bench used by the simulation, sweep and linearization tests."""

from __future__ import annotations

import pytest

import fl_design as fl

T_BENCH = 1e-3


def pytest_report_header(config):
    """The machine and instruction set the compiled kernels of this run use (first lines)."""
    try:
        info = fl.Kernel().describe()
    except Exception as exc:  # noqa: BLE001 - e.g. a bad $FL_DESIGN_ISA: say it, tests say more
        return [f"fl_design kernel: cannot resolve ({exc})"]
    line = (f"fl_design kernel: {info['cpu']} ({info['machine']}), isa {info['isa']} "
            f"({info['lanes']} lanes, {info['isa_source']}); available: "
            f"{', '.join(info['available'])}; compiler {info['compiler']} (lanes kernel: "
            f"{info['lanes_compiler']})")
    return [line]


@pytest.fixture(scope="session")
def pendulum():
    """The library's damped pendulum (relative degree 2)."""
    return fl.plants.pendulum()


@pytest.fixture(scope="session")
def pendulum_design():
    """Factory of the pendulum bench design: EHGO (poles at -1/eps), K = (2, 4), T = 1 ms."""

    def make(eps=0.02, gamma=1e-2, **kw):
        return fl.Design(estimator=fl.EHGO(rho=2, eps=eps, T=T_BENCH),
                         controller=fl.DynamicController((2, 4), gamma, **kw))

    return make


@pytest.fixture(autouse=True, scope="module")
def _close_figures():
    """Close the pyplot figures a test module opened (plot functions return pyplot figures,
    as a notebook user expects; the suite must not accumulate them: matplotlib warns past 20).
    Per module, not per test: module-scoped fixtures hold figures across their tests."""
    yield
    import sys

    plt = sys.modules.get("matplotlib.pyplot")  # only when the tests imported it
    if plt is not None:
        plt.close("all")
