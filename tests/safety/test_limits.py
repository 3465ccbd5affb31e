"""Resource bounds and strict environment/config parsing (issue 19): clear errors up front."""

from __future__ import annotations

import pytest

import fl_design as fl
from fl_design._limits import (
    MAX_SUBSTEPS,
    check_memory,
    check_substeps,
    env_flag,
    env_limit,
    memory_budget,
)
from fl_design.app import load_config, parse_config
from fl_design.app._config import MAX_CERTIFY_POINTS, MAX_SWEEP_POINTS, ConfigError
from fl_design.errors import ParameterError, ResourceLimitError
from fl_design.sim import ClosedLoop, Noise


@pytest.mark.parametrize("text", ["inf", "-inf", "nan", "1e999", "-1", "0", "banana", "0x10",
                                  "4 GB", "1_000"])
def test_every_limit_variable_is_parsed_strictly(text, monkeypatch):
    monkeypatch.setenv("FL_DOC_LIMIT", text)
    with pytest.raises(ParameterError, match=r"\$FL_DOC_LIMIT=.* must be a positive number of GiB, finite"):
        env_limit("FL_DOC_LIMIT", 4.0, unit="GiB", integer=False)


@pytest.mark.parametrize("text, value", [("2", 2.0), (" 1.5 ", 1.5), ("1e3", 1000.0),
                                         (".5", 0.5), ("", 4.0)])
def test_good_limit_values(text, value, monkeypatch):
    monkeypatch.setenv("FL_DOC_LIMIT", text)
    assert env_limit("FL_DOC_LIMIT", 4.0, unit="GiB", integer=False) == value


def test_memory_env_inf_is_refused(monkeypatch):
    monkeypatch.setenv("FL_DESIGN_MAX_MEMORY_GB", "inf")
    with pytest.raises(ParameterError, match="FL_DESIGN_MAX_MEMORY_GB='inf'"):
        memory_budget()


@pytest.mark.parametrize("text, expected", [("0", False), ("1", True), ("", True)])
def test_flags(text, expected, monkeypatch):
    monkeypatch.setenv("FL_DOC_FLAG", text)
    assert env_flag("FL_DOC_FLAG", True) is expected


@pytest.mark.parametrize("text", ["banana", "yes", "2", "true"])
def test_bad_flags(text, monkeypatch):
    monkeypatch.setenv("FL_DOC_FLAG", text)
    with pytest.raises(ParameterError, match="must be 0 \\(off\\) or 1 \\(on\\)"):
        env_flag("FL_DOC_FLAG", True)


@pytest.mark.parametrize("n", [MAX_SUBSTEPS + 1, 10**6, 10**9])
def test_substeps_above_the_cap_are_refused_before_any_work(n):
    with pytest.raises(ResourceLimitError, match=f"substeps={n} is above the limit of "
                       f"{MAX_SUBSTEPS}.*FL_DESIGN_MAX_SUBSTEPS"):
        fl.RK4(substeps=n)
    with pytest.raises(ResourceLimitError):
        ClosedLoop(fl.plants.pendulum(), fl.Design(
            estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
            controller=fl.DynamicController((2, 4), 1e-2)), substeps=n)


def test_the_substeps_cap_is_overridable(monkeypatch):
    monkeypatch.setenv("FL_DESIGN_MAX_SUBSTEPS", "20000")
    assert check_substeps(MAX_SUBSTEPS + 1) == MAX_SUBSTEPS + 1
    assert fl.RK4(substeps=MAX_SUBSTEPS).substeps == MAX_SUBSTEPS


def test_a_long_run_over_the_memory_cap_is_refused_up_front(monkeypatch):
    monkeypatch.setenv("FL_DESIGN_MAX_MEMORY_GB", "1.5")
    design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
                       controller=fl.DynamicController((2, 4), 1e-2))
    with pytest.raises(ResourceLimitError, match=r"recording a run of 3e\+07 samples needs "
                       r"about 3.\d+ GiB, above 1.5 GiB|about 3.\d+ GiB, above 1.[0-4]\d* GiB"):
        fl.simulate(fl.plants.pendulum(), design, fl.Scenario(0.1, 3e4))


def test_check_memory_names_the_bound():
    check_memory(1.0, "nothing", "n/a")
    with pytest.raises(ResourceLimitError, match="a huge thing needs about"):
        check_memory(1e30, "a huge thing", "make it smaller")


PLANT = '[plant]\nstates = ["x1", "x2"]\ninput = "u"\nrhs = ["x2", "-x1 + u"]\noutput = "x1"\n'


@pytest.mark.parametrize("text, match", [
    ("[sweep]\npoints = 1000000000000000000000000000000\n",
     f"points must be >= 2 and <= {MAX_SWEEP_POINTS}"),
    ("[certify]\npoints = 100000000000\n", f"<= {MAX_CERTIFY_POINTS}"),
    ("[scenario]\nseed = -5\n", "noise seed must be >= 0, got -5"),
    ("[compare]\nseed = -5\n", "noise seed must be >= 0, got -5"),
    ("[scenario]\nnoise_std = -1.0\n", "std"),
    ("[compare]\nwindows = [0, 5]\n", r"windows must hold integers in \[1, "),
    (PLANT + 'region = {x1 = ["a", 1]}\n',
     r"\[plant\] region.x1 must be a sequence of real numbers \(int or float\): entry 0 is 'a'"),
    (PLANT + 'input_range = [1]\n', r"\[plant\] input_range must have length 2, got 1"),
    ('[plant]\nstates = ["x 1", "x2"]\ninput = "u"\nrhs = ["x2", "u"]\noutput = "x2"\n',
     "states must be a name"),
])
def test_config_values_are_refused_like_the_api_refuses_them(text, match):
    with pytest.raises(ConfigError, match=match):
        parse_config(text)


def test_config_and_api_agree_on_seeds():
    with pytest.raises(ParameterError):
        Noise(std=0.0, seed=-5)
    assert parse_config("[scenario]\nseed = 0\n").scenario.seed == 0
    assert Noise(std=0.0, seed=0).seed == 0


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf[design]\neps = 0.1\n")
    assert load_config(path).design.eps == 0.1
    assert parse_config("\ufeff[design]\neps = 0.2\n").design.eps == 0.2
