"""eps_star_curve names the class it certifies: each constant b (its frozen pieces), not b
varying in time (a switching attack beat that label: verify/attack_certificates.py), and says
where the varying-b certificate is; progress lines as asked."""
import numpy as np

import fl_design as fl


def _design():
    return fl.Design(estimator=fl.EHGO(2, 1e-2, 1e-3), controller=fl.DynamicController(
        fl.synthesize_gains(2, decay=1.0).gains, 0.5 / 50))


def test_a_frozen_curve_names_constant_b_and_leaves_varying_b_uncovered(capsys):
    cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0))
    assert "varying arbitrarily" in cls.describe()
    c = fl.eps_star_curve(_design(), cls, [2e-3, 1e-2], eps_range=(1e-3, 1.0), progress=False)
    assert c.covers == "frozen"
    assert "b in [1, 50] constant per plant" in c.class_description
    assert "varying" not in c.class_description
    assert c.plant_class.b_rate == 0.0 and c.plant_class.b == cls.b
    assert any(u.startswith("b varying in time") and "fl.certify_eps" in u for u in c.uncovered)
    assert capsys.readouterr().err == ""


def test_a_class_of_constant_b_is_named_as_given(capsys):
    cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0), b_rate=0.0)
    calls = []
    c = fl.eps_star_curve(_design(), cls, [2e-3, 1e-2], eps_range=(1e-3, 1.0),
                          progress=lambda done, total: calls.append((done, total)))
    assert c.class_description == cls.describe()
    assert not any(u.startswith("b varying in time") for u in c.uncovered)
    assert calls == [(1, 2), (2, 2)]


def test_progress_true_says_each_gain_on_stderr(capsys):
    fl.eps_star_curve(_design(), (1.0, 50.0), np.geomspace(2e-3, 1e-2, 3),
                      eps_range=(1e-3, 1.0), progress=True)
    err = capsys.readouterr().err.splitlines()
    assert [x.split(",")[0] for x in err] == ["[fl.eps_star_curve] 1/3 gains",
                                              "[fl.eps_star_curve] 2/3 gains"]
