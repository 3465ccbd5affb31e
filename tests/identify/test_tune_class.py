"""fl.tune(plant_class): a design certified for the whole class, checked independently: the
noise gain against a brute-force impulse sum, the frozen loop against an independent NumPy/SciPy
construction over b, the member runs."""
import json
import math

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

import fl_design as fl
from fl_design.errors import ParameterError
from fl_design.tuning._class_checks import surrogate_noise_gain
from fl_design.tuning._tune_class import tune_class


def independent_radius(design, b):
    """Sampled loop (exact ZOH chain, bilinear scaled EHGO, dynamic law), written apart."""
    est, ctrl = design.estimator, design.controller
    rho, T, eps = est.rho, est.T, est.eps
    a = np.asarray(est.alphas, float)
    F = np.diag(np.ones(rho), 1)
    F[:, 0] -= a
    Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete((F, a.reshape(-1, 1), np.eye(rho + 1),
                                                    np.zeros((rho + 1, 1))), T / eps,
                                                   method="bilinear")
    Dinv = np.diag([eps ** -i for i in range(rho + 1)])
    Ac = np.diag(np.ones(rho - 1), 1)
    E = scipy.linalg.expm(np.block([[Ac, np.eye(rho)[:, -1:]], [np.zeros((1, rho + 1))]]) * T)
    Ap, Bp = E[:rho, :rho], E[:rho, rho:]
    n = rho + 1 + rho + 1  # x, u, xi
    Cy = np.zeros((1, n)); Cy[0, 0] = 1
    Sxi = np.zeros((rho + 1, n)); Sxi[:, rho + 1:] = np.eye(rho + 1)
    Xh = Dinv @ (Cd @ Sxi + Dd @ Cy)
    U = np.zeros((1, n)); U[0, rho] = 1
    v = -sum(k * Xh[i:i + 1] for i, k in enumerate(ctrl.gains))
    un = U + ctrl.gamma * (v - Xh[rho:rho + 1])
    M = np.zeros((n, n))
    Sx = np.zeros((rho, n)); Sx[:, :rho] = np.eye(rho)
    M[:rho] = Ap @ Sx + b * Bp @ un
    M[rho] = un
    M[rho + 1:] = Ad @ Sxi + Bd @ Cy
    return max(abs(np.linalg.eigvals(M)))


@pytest.fixture(scope="module")
def wide():
    cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0), noise_std=1e-3, u_limits=(-10.0, 10.0))
    return fl.tune(cls)


def test_wide_class_is_certified_and_the_independent_loop_agrees(wide):
    assert wide.certified, wide.eps_certificate.reason
    worst = max(independent_radius(wide.design, b) for b in np.geomspace(1, 50, 30))
    assert worst < 1.0
    assert wide.converged and len(wide.members) == 5
    assert {m.b_lo for m in wide.members} >= {1.0, 50.0}


def test_margins_at_both_ends_and_noise_gain(wide):
    assert [m.b for m in wide.margins] == [1.0, 50.0]
    for m in wide.margins:
        assert m.gain_margins[0] < 1 < m.gain_margins[1] and m.phase_margin > 0
    ng = wide.noise_gain["50"]
    assert ng["u"] > 0 and math.isfinite(ng["u"])


def test_noise_gain_equals_the_impulse_response_sum():
    cls = fl.PlantClass(rho=2, T=1e-3, b=(2.0, 10.0))
    d = tune_class(cls, reference=1.0, members=False).design
    from fl_design.analysis._surrogate import SurrogateLoop

    loop = SurrogateLoop(d)
    M0, M1 = loop.parts()
    M = M0 + 10.0 * M1
    Js, Jy, _us, uy = loop._jacobians(None, None)
    N = np.zeros(2 + Js.shape[0]); N[2:] = np.asarray(Jy).ravel(); N = N[loop.keep]
    row = loop.input_row()[loop.keep]
    x, total = N.copy(), float(uy.item()) ** 2
    for _ in range(200000):
        total += float(row @ x) ** 2
        x = M @ x
    assert surrogate_noise_gain(d, 10.0)["u"] == pytest.approx(math.sqrt(total), rel=1e-6)


@pytest.mark.slow
def test_negative_b_class_with_slopes_and_delay_runs_its_corners():
    cls = fl.PlantClass(rho=2, T=1e-3, b=(-8.0, -2.0), a_slopes=((-1.0, 1.0), (-0.2, 0.2)),
                        noise_std=1e-4, u_limits=(-20.0, 20.0), delay=2)
    t = tune_class(cls, reference=0.5)
    assert "the 2-sample input delay" in t.uncovered
    assert t.design.controller.gamma < 0
    corners = [m for m in t.members if "corner" in m.member]
    assert len(corners) == 8 and t.converged, repr(t)
    assert json.loads(json.dumps(t.to_dict(), allow_nan=False))["plant_class"]["b"] == [-8, -2]


def test_a_class_without_T_or_a_bad_objective_is_refused():
    with pytest.raises(ParameterError, match="the class has no T"):
        tune_class(fl.PlantClass(rho=2, T=None, b=(1, 2)))
    with pytest.raises(ParameterError, match="objective='overshoot'"):
        fl.tune(fl.PlantClass(rho=2, T=1e-3, b=(1, 2)), objective="overshoot")


def test_the_class_default_is_least_noise_and_fastest_keeps_converging_members(wide):
    """fl.tune(class) without an objective ranks by noise (the fastest certified loop of
    b in [1, 50] amplified the 1e-3 sensor noise ~5000-fold and no member converged); with
    "fastest" a certified candidate whose members do not converge is passed over, and said.
    ``wide`` is ``fl.tune`` of this class without an objective (the module's fixture)."""
    cls = wide.plant_class
    default = wide
    assert cls == fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0), noise_std=1e-3,
                                u_limits=(-10.0, 10.0))
    assert default.objective == "least-noise" and default.certified
    assert all(m.converged for m in default.members)
    fast = fl.tune(cls, objective="fastest")
    assert fast.certified and all(m.converged for m in fast.members)
    assert fast.time_scale >= default.time_scale  # fastest is no slower than least-noise


def test_when_noise_saturates_every_usual_candidate_a_slower_one_is_certified_and_converges():
    """rho = 3, b in [20, 200], T = 0.5 ms, noise std 1e-4, u in [-12, 12]: at
    |gamma| |b|_max = 0.1-0.5 the certified eps is ~1 ms or less and the sensor noise reaches u
    ~1e5-fold (u saturates, no member converges); the slower candidates (0.03, 0.01) give a
    larger eps* and a design certified for the class whose members converge. Its frozen loops
    over b are checked Schur with the module's independent construction."""
    from fl_design.tuning._tune_class import GAMMA_FRACTIONS, SLOW_FRACTIONS

    cls = fl.PlantClass(rho=3, T=5e-4, b=(20.0, 200.0), noise_std=1e-4, u_limits=(-12.0, 12.0))
    tuned = fl.tune(cls)
    c = abs(tuned.design.controller.gamma) * 200.0
    assert c == pytest.approx(min(SLOW_FRACTIONS)) and c < min(GAMMA_FRACTIONS)
    assert tuned.certified, tuned.eps_certificate.reason
    assert tuned.members and all(m.converged for m in tuned.members)
    assert sum("member runs do not converge" in t for t in tuned.tried) == len(GAMMA_FRACTIONS)
    worst = max(independent_radius(tuned.design, b) for b in np.geomspace(20, 200, 12))
    assert worst < 1.0
    # 3 sigma of the noise in u stays well inside the input range (it did not at c = 0.1)
    assert 3 * 1e-4 * max(g["u"] for g in tuned.noise_gain.values()) < 0.1 * 12.0


def test_tune_of_a_class_with_progress_says_each_step_on_stderr(capsys):
    cls = fl.PlantClass(rho=2, T=1e-3, b=(2.0, 8.0), noise_std=1e-3, u_limits=(-10, 10))
    fl.tune(cls, reference=1.0, progress=True)
    err = capsys.readouterr().err.splitlines()
    assert err and all(x.startswith("[fl.tune] ") and x.endswith(" s)") for x in err)
    assert "candidate 1/3, |gamma| |b|_max = 0.5: frozen-b eps* scan" in err[0]
    fl.tune(cls, reference=1.0, progress=False)
    assert capsys.readouterr().err == ""
    with pytest.raises(ParameterError, match="progress='yes' is not valid: True"):
        fl.tune(cls, progress="yes")


def test_a_class_with_a_delay_is_certified_without_it_and_says_so():
    """The certificates' loop has no input delay: the certificate names the class with
    delay 0 and lists the delay as not covered; the reasons weigh it against the delay
    margins (the member runs include it)."""
    from types import SimpleNamespace

    from fl_design.tuning._tune_class import _delay_words

    cls = fl.PlantClass(rho=1, T=0.02, b=(0.05, 0.2), noise_std=0.05, u_limits=(0.0, 100.0),
                        delay=10, operating_point=50.0, u_eq=40.0)
    tuned = fl.tune(cls, reference=55.0, progress=False)
    cert = tuned.eps_certificate
    assert cert.plant_class.delay == 0 and "no input delay" in cert.class_description
    assert "the 10-sample input delay" in cert.uncovered
    words = [r for r in tuned.reasons if r.startswith("input delay 10 samples = 0.2 s")]
    assert len(words) == 1 and "not covered by the certificate" in words[0]
    m = lambda b, dm: SimpleNamespace(b=b, delay_margin=dm)
    assert "within the smallest delay margin 0.5 s (b = 2)" in _delay_words(
        cls, [m(1.0, 0.9), m(2.0, 0.5)])[0]
    assert "BEYOND" in _delay_words(cls, [m(1.0, 0.9), m(2.0, 0.1)])[0]
    assert _delay_words(fl.PlantClass(rho=1, T=0.02, b=(0.05, 0.2)), [m(1.0, 0.1)]) == ()
