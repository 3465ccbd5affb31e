"""The practitioner's baseline, linear ADRC: closed-form gains, and against the reference model
it is tuned for: with b0 = b its step follows (s + w_c)^rho, whose 2 % settling time is known in
closed form; a b0 ten times too large breaks it in the same run."""
import math

import numpy as np
import pytest
import scipy.optimize

from fl_design.design._adrc import LinearADRC
from fl_design.errors import ParameterError
from fl_design.sim._rig import chain_rig
from fl_design.tuning._class_checks import _metrics


def test_gains_are_the_binomial_bandwidth_parameterization():
    c = LinearADRC(rho=3, T=1e-3, b0=1.0, wc=2.0, wo=7.0)
    assert np.allclose(np.poly([-7.0] * 4)[1:], c.observer_gains)
    assert np.allclose(np.poly([-2.0] * 3)[1:][::-1], c.controller_gains)


def test_with_b0_equal_to_b_the_step_settles_as_its_reference_model():
    wc = 2.0
    # (s + wc)^2 step: 1 - (1 + wc t) exp(-wc t); 2 % band reached at wc t = x
    x = scipy.optimize.brentq(lambda s: (1 + s) * math.exp(-s) - 0.02, 1.0, 20.0)
    adrc = LinearADRC(rho=2, T=1e-3, b0=5.0, wc=wc, wo=20 * wc)
    log = chain_rig(2, b=5.0, T=1e-3).run(adrc, 1.0, 8.0)
    m = _metrics(log, 1.0, 0.0, 0.0, "chain", 5.0, 5.0)
    assert m.converged and m.settling_time == pytest.approx(x / wc, rel=0.05)


def test_b0_ten_times_too_large_does_not_converge_in_the_same_run():
    adrc = LinearADRC(rho=2, T=1e-3, b0=50.0, wc=2.0, wo=20.0, u_limits=(-10, 10))
    log = chain_rig(2, b=5.0, T=1e-3, noise_std=1e-3).run(adrc, 1.0, 8.0)
    assert not _metrics(log, 1.0, 0.0, 1e-3, "chain", 5.0, 5.0).converged


def test_b0_zero_is_refused():
    with pytest.raises(ParameterError, match="b0 must be nonzero"):
        LinearADRC(rho=2, T=1e-3, b0=0.0, wc=1.0, wo=5.0)
