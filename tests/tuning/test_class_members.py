"""Member runs of a class design: members held at the class's operating point by its u_eq, and
runs as long as the loop asks (a slow loop at a long T is not cut at 60 s)."""
import numpy as np
import pytest

import fl_design as fl
from fl_design.tuning._class_checks import MAX_RUN, member_rig, member_runs
from fl_design.tuning._tune_class import _candidate

# a thermal loop: rho = 1, T = 20 ms, the heater at 40 % holds 50 degrees, a 10-sample delay
OVEN = {"rho": 1, "T": 0.02, "b": (0.05, 0.2), "noise_std": 0.05, "u_limits": (0.0, 100.0),
        "operating_point": 50.0, "u_eq": 40.0}


def _design(c, delay=0):
    cls = fl.PlantClass(**OVEN, delay=delay)
    cand = _candidate(cls, c, cls.u_limits)
    return cls, cand, cand["design"].replace(eps=0.25 * cand["frozen"])


@pytest.mark.parametrize("b", [0.05, 0.2])
def test_member_is_the_class_model_in_closed_form(b):
    """Every sample: y(k+1) - y(k) = b T (u(k) - u_eq) (rho = 1, ZOH, no delay), and at rest at
    the operating point under u_eq."""
    _, _, d = _design(0.1)
    rig = member_rig(1, b=b, T=0.02, y0=50.0, u_eq=40.0)
    log = rig.run(d, 55.0, 20.0, seed=0, u0=40.0)
    dy = np.diff(log.y_true)
    np.testing.assert_allclose(dy, b * 0.02 * (log.u[:-1] - 40.0), rtol=1e-9, atol=1e-12)
    rest = rig.run(d, 50.0, 5.0, seed=0, u0=40.0)
    assert np.max(np.abs(rest.y_true - 50.0)) < 1e-9
    assert np.max(np.abs(rest.u - 40.0)) < 1e-9


def test_slow_members_of_a_class_with_u_eq_converge_and_are_not_cut_at_60_s():
    """The slowest candidate of the oven (decay 0.025 rad/s: 480 s runs) converges on every
    member; it was judged on plants drifting at b u_eq (a = 0 with u = 40) for at most 60 s."""
    cls, cand, d = _design(0.01, delay=10)
    runs = member_runs(d, cls, 55.0, 12.0 / cand["decay"], seed=0)
    assert len(runs) == 5
    assert all(m.converged for m in runs), [m.line() for m in runs]
    assert all(m.settling_time > MAX_RUN for m in runs)  # needs the run past 60 s
    assert all(m.u_peak < 50.0 for m in runs)  # u stays near u_eq = 40: no drift to undo


def test_tune_of_a_plant_names_the_class_its_certificate_covers():
    """fl.tune(plant) certifies the chain with the plant's b-range and a = 0; the reason says so
    (the ball and beam's run printed 'certified: eps True' above a report 'NOT certified')."""
    plant = fl.plants.pendulum()
    tuned = fl.tune(plant, reference=0.1)
    line = next(r for r in tuned.reasons if r.startswith("certified:"))
    lo, hi = sorted(tuned.eps_certificate.b_bounds)
    assert f"b in [{lo:.6g}, {hi:.6g}], a = 0" in line
    assert "not this plant's class" in line
    assert tuned.eps_certificate.a_jacobian_bounds is None  # indeed no slopes of a in it
