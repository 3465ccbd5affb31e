"""Identification on the virtual rig: the class contains the true b range of the visited states,
the delay and noise are found, and the design from the class converges on the plant that wrote
the log (a plant fl_design never saw: its b depends on the state)."""
import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import LogError
from fl_design.sim._rig import chain_rig
from fl_design.tuning._class_checks import _metrics
from fl_design.tuning._tune_class import tune_class

from .conftest import pendulum_rig, square, steps


def test_chain_log_gives_b_delay_noise_and_quantization(chain_log):
    cls = fl.identify(chain_log.columns(), rho=2)
    ev = cls.evidence
    assert cls.source == "log" and cls.b[0] <= 5.0 <= cls.b[1]
    assert cls.delay == 3
    # the noise the rig added (std 1e-3) plus its quantization (q^2 / 12), measured apart
    truth = np.std(chain_log.y - chain_log.y_true)
    assert cls.noise_std == pytest.approx(truth, rel=0.05)
    assert ev.quantization == pytest.approx(2e-4, rel=1e-6)
    assert ev.agreement, ev.agreement_text
    for name in ("local-ls", "ehgo-sigmahat"):
        e = ev.estimators[name]
        assert e["b_lo"] <= 5.0 <= e["b_hi"] and abs(e["median"] / 5.0 - 1) < 0.05


def test_csv_and_columns_give_the_same_class(chain_log, tmp_path):
    path = chain_log.write_csv(tmp_path / "rig.csv")
    a = fl.identify(path, rho=2)
    b = fl.identify(chain_log.columns(), rho=2)
    assert a.b == pytest.approx(b.b, rel=1e-6) and a.delay == b.delay and a.name == "rig"


def test_wrong_sign_b_is_refused(narrow_design):
    rig = chain_rig(2, b=5.0, T=1e-3, noise_std=1e-3)
    log = rig.run(narrow_design, steps(2.0), 8.0, excitation=square(0.125, 0.5)).columns()
    flipped = dict(log, u=-log["u"])  # a negated u column (actuator wired backwards)
    with pytest.raises(LogError, match="b < 0 .* but b_sign = \\+1: is u's sign flipped"):
        fl.identify(flipped, rho=2, b_sign=1)


@pytest.mark.slow
def test_unseen_plant_class_contains_its_b_and_the_design_converges_on_it(narrow_design):
    rig = pendulum_rig(noise_std=1e-3, quantization=1e-4, delay=1)
    log = rig.run(narrow_design, steps(3.0, 0.2, 1.0), 30.0, seed=3,
                  excitation=square(0.125, 1.0))
    lo, hi = log.b_range  # the true b over the visited states
    cls = fl.identify(log.columns(), rho=2, u_limits=(-20.0, 20.0))
    assert cls.b[0] <= lo and hi <= cls.b[1], (cls.b, (lo, hi))
    assert cls.delay >= 1
    tuned = tune_class(cls, reference=0.6, members=False)
    run = rig.run(tuned.design, 0.6, 20.0, seed=4, u0=0.0)
    m = _metrics(run, 0.6, 0.0, cls.noise_std, "pendulum", lo, hi)
    assert m.converged, m.line()


def test_the_page_has_its_plots_and_the_command(chain_log, tmp_path):
    from fl_design.identification import write_page

    cls = fl.identify(chain_log.columns(), rho=2)
    paths = write_page(cls, tmp_path)
    text = paths["markdown"].read_text()
    assert "identify_fit.png" in text and "fl-design run" in text
    assert all(paths[k].stat().st_size > 1000 for k in ("fit", "residuals", "noise"))


def test_evidence_is_strict_json(chain_log):
    import json

    d = fl.identify(chain_log.columns(), rho=2).to_dict()
    back = json.loads(json.dumps(d, allow_nan=False))
    assert back["source"] == "log" and back["evidence"]["delay"] == 3


@pytest.mark.parametrize("rho, b, T", [(1, -3.0, 5e-3), (2, -20.0, 2e-3)])
def test_any_controllers_log_works_rho_sign_and_rate(rho, b, T):
    """An ADRC (not fl's design) wrote the log: the u column is what was applied."""
    from fl_design.design._adrc import LinearADRC

    adrc = LinearADRC(rho=rho, T=T, b0=b * 1.5, wc=3.0, wo=30.0, u_limits=(-50.0, 50.0))
    rig = chain_rig(rho, b=b, T=T, noise_std=5e-4)
    log = rig.run(adrc, steps(2.0), 40.0, seed=5, excitation=square(0.5, 0.3))
    cls = fl.identify(log.columns(), rho=rho, b_sign=-1)
    assert cls.b[0] <= b <= cls.b[1] < 0 and cls.T == pytest.approx(T)
    assert cls.evidence.agreement, cls.evidence.agreement_text
