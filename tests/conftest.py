"""Shared fixtures: the pendulum test bench used by the simulation, sweep and linearization tests."""

from __future__ import annotations

import pytest

import fl_design as fl

T_BENCH = 1e-3


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
