"""eps_star_curve's continuation keeps every certificate a gain finds alone (issue 33: the
split of b that certified one gain made the next gains skip the whole-range LMI, and a low
hint from the previous gain made the search step down past the eps that certify (they are
not monotone in eps); a 12-gain curve of rho = 2, b in [1, 50] certified 5 gains, now 8)."""

import numpy as np
import pytest

import fl_design as fl


@pytest.mark.slow
def test_curve_certifies_each_gain_its_single_gain_search_certifies():
    T = 1e-3
    design = fl.Design(estimator=fl.EHGO(2, 10 * T, T), controller=fl.DynamicController(
        fl.synthesize_gains(2, decay=1.0).gains, 0.01))
    cls = fl.PlantClass(rho=2, T=T, b=(1.0, 50.0))
    gammas = np.geomspace(0.02 / 50, 1 / 50, 12)[3:7]
    curve = fl.eps_star_curve(design, cls, gammas)
    alone = np.array([fl.eps_star_curve(design, cls, [g]).eps_star_certified[0]
                      for g in gammas])
    assert np.all(np.isfinite(alone))  # the class's gains are certifiable one by one ...
    assert np.all(np.isfinite(curve.eps_star_certified))  # ... and so along the curve
    # the searches start from different hints (the certificate forms are not monotone in
    # eps, so the eps* found depends on the path): close, not equal
    assert np.all(curve.eps_star_certified >= 0.8 * alone)
    assert np.all(curve.eps_star_certified <= curve.eps_star_frozen)  # a certificate is
    # never above the frozen eps* (an eigenvalue refutation above it)
