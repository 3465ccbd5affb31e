"""A log where a(x) moves within a window: a DC motor's speed loop (rho = 1, back-EMF slope
-63 /s, b = 1250) under a PI controller. With a only a polynomial in time per window, b came out
NEGATIVE (-624 .. -87) and the delay 20 samples (the search's end) for 0; with a's slope in y
fitted per window both are right. The log is written by the exact ZOH solution of the plant."""
import math

import numpy as np

import fl_design as fl

B_TRUE, ALPHA = 1250.0, 63.0  # w' = -ALPHA w + B_TRUE (u - U_C): back-EMF and friction


def motor_log(seed: int, noise: float = 0.5, T: float = 1e-3, n: int = 6000) -> dict:
    """PI speed loop, steps 150 <-> 50 rad/s every 0.5 s; Coulomb friction as an input offset
    U_C (w > 0 throughout), so each sample is w+ = e^(-ALPHA T) w + B/ALPHA (1 - e) (u - U_C)."""
    rng = np.random.default_rng(seed)
    e1 = math.exp(-ALPHA * T)
    g = B_TRUE / ALPHA * (1.0 - e1)
    u_c = 0.04
    t = np.arange(n) * T
    r = np.where((t // 0.5) % 2 == 0, 150.0, 50.0)
    w, integ = 100.0, 5.08
    y, u = np.empty(n), np.empty(n)
    for k in range(n):
        y[k] = w + noise * rng.standard_normal()
        e = r[k] - y[k]
        u[k] = min(max(0.02 * e + integ, 0.0), 24.0)
        integ += 1.0 * e * T
        w = e1 * w + g * (u[k] - u_c)
    assert np.all(y > 20.0)  # the friction's sign never changes
    return {"t": t, "y": y, "u": u, "r": r}


def test_a_moving_within_windows_is_fitted_and_b_and_the_delay_are_right():
    cls = fl.identify(motor_log(seed=3), rho=1)
    ev = cls.evidence
    assert cls.b[0] <= B_TRUE <= cls.b[1], cls.b
    assert cls.delay == 0
    assert "slopes in y fitted" in ev.a_model
    for name in ("local-ls", "ehgo-sigmahat"):
        assert abs(ev.estimators[name]["median"] / B_TRUE - 1.0) < 0.1, ev.estimators[name]
    assert ev.agreement, ev.agreement_text


def test_a_chain_log_keeps_a_as_a_polynomial_in_time(chain_log):
    ev = fl.identify(chain_log.columns(), rho=2).evidence
    assert ev.a_model.startswith("a as a polynomial in time")
    assert ev.to_dict()["a_model"] == ev.a_model


def test_u_eq_is_read_from_the_steady_windows_and_the_members_hold_there():
    """The motor rests at 50 and 150 rad/s; the input holding it at the operating point 100 is,
    in closed form, u_eq = ALPHA / B_TRUE * 100 + U_C = 5.08 (the line through the two rests)."""
    cls = fl.identify(motor_log(seed=3), rho=1, u_limits=(0.0, 24.0))
    assert cls.operating_point == 100.0
    want = ALPHA / B_TRUE * 100.0 + 0.04
    assert abs(cls.u_eq - want) < 0.01 * want, cls.u_eq
    assert any(n.startswith("u_eq = ") for n in cls.notes)


def test_u_eq_is_not_guessed_from_a_log_that_never_rests():
    log = motor_log(seed=3)
    t = log["t"]
    moving = {**log, "y": log["y"] + 400.0 * t}  # a ramp of 400 rad/s per s: never steady
    cls = fl.identify(moving, rho=1)
    assert cls.u_eq is None
    assert any(n.startswith("u_eq not estimated") for n in cls.notes)
