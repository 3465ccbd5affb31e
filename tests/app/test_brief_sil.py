"""The summary's C line says why SIL failed: a loop that fails in C as in Python is the design's
failure under the SIL scenario (the ball and beam at noise 1/300 of its step), not a C error."""
from types import SimpleNamespace

import numpy as np

from fl_design.app._brief import code_brief
from fl_design.codegen import SilResult

COST = SimpleNamespace(rows=[SimpleNamespace(flops=98, ns_per_step=13.0, stack_bytes=120)])


def _cg(sil):
    return {"sil": sil, "costs": COST, "sil_duration": 10.0, "sil_noise_std": 1.67e-4}


def test_a_loop_diverging_in_c_and_python_is_said_as_the_design_failing():
    # the C holds u after the plant left its range (fault), Design.step does not: error 2
    u_ref = np.array([-20.0, -15.4, -1.1, 20.0])
    u_c = np.array([-20.0, -15.4, -15.4, -15.4])
    sil = SilResult("double", np.zeros(4), u_c, u_ref, 1e-12, "diverged", "diverged", False, True)
    assert not sil.passed and sil.max_rel_error > 1.0
    text = str(code_brief(_cg(sil)))
    assert text.startswith("SIL FAILED")
    assert "diverged under noise std 0.000167 in C as in Python" in text
    assert "the design fails this scenario" in text


def test_a_c_step_that_differs_from_python_stays_a_plain_failure():
    u_ref = np.array([1.0, 2.0])
    sil = SilResult("double", np.zeros(2), np.array([1.0, 2.5]), u_ref, 1e-12, "converged",
                    "converged", True, False)
    text = str(code_brief(_cg(sil)))
    assert text.startswith("SIL FAILED") and "in C as in Python" not in text
    assert "error 0.25 (bound 1e-12)" in text
