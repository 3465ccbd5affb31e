"""Shared pieces of the model-free route's tests: a cheap class design and rig logs."""
import casadi as ca
import numpy as np
import pytest

import fl_design as fl
from fl_design.sim._rig import Rig, chain_rig
from fl_design.tuning._tune_class import tune_class


@pytest.fixture(scope="package")
def narrow_design():
    """A design certified for b in [2, 10] (no member runs: fast)."""
    return tune_class(fl.PlantClass(rho=2, T=1e-3, b=(2.0, 10.0), u_limits=(-20.0, 20.0)),
                      reference=1.0, members=False).design


def square(period, amp):
    return lambda t: amp * np.sign(np.sin(2 * np.pi * t / period) + 1e-12)


def steps(period, lo=0.0, hi=1.0):
    return lambda t: lo + (hi - lo) * ((t // period) % 2)


def pendulum_rig(noise_std=1e-3, quantization=None, delay=0):
    """y'' = -9.81 sin y - 0.1 y' + (3 + 2 cos y) u: b depends on the state (never seen by fl)."""
    return Rig(ode=lambda x, u, p: [x[1], -9.81 * ca.sin(x[0]) - 0.1 * x[1]
                                    + (3 + 2 * ca.cos(x[0])) * u],
               x0=(0.0, 0.0), T=1e-3, b=lambda x, p: 3 + 2 * ca.cos(x[0]),
               noise_std=noise_std, quantization=quantization, delay=delay, name="pendulum")


@pytest.fixture(scope="package")
def chain_log(narrow_design):
    """Chain b = 5 with noise 1e-3, quantization 2e-4, 3 samples of delay, excited."""
    rig = chain_rig(2, b=5.0, T=1e-3, noise_std=1e-3, quantization=2e-4, delay=3)
    return rig.run(narrow_design, steps(2.0), 20.0, seed=2, excitation=square(0.125, 0.5))
