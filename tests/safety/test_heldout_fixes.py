"""Findings of the held-out fault variants (``verify/fault_cases_heldout.py``), one test each:
nested exponentials, a FIFO at the cache key's path, overlong names, terminal escapes."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import time

import pytest
import sympy as sp

import fl_design as fl
from fl_design.errors import ExpressionError, ParameterError, PlantDefinitionError

x1, x2, u = sp.symbols("x1 x2 u", real=True)


def _tower(n: int, inner=x1):
    e = inner
    for _ in range(n):
        e = sp.exp(e)
    return e


@pytest.mark.parametrize("make", [lambda: _tower(4), lambda: sp.sinh(sp.cosh(_tower(2))),
                                  lambda: 2 ** (2 ** (sp.exp(sp.exp(x1))))])
def test_exponentials_nested_more_than_three_deep_are_refused_at_once(make):
    start = time.perf_counter()
    with pytest.raises(ExpressionError, match=r"rhs\[1\].*exponentials nested more than 3 deep"):
        fl.Plant.from_ode([x1, x2], u, [x2, make() + u], x1)
    assert time.perf_counter() - start < 10


def test_three_nested_exponentials_still_derive_exactly():
    p = fl.Plant.from_ode([x1, x2], u, [x2, -_tower(3) + sp.exp(sp.exp(sp.E)) + u], x1)
    assert p.relative_degree() == 2
    nf = p.normal_form()
    # y'' = a + b u with b = 1 and a the rest: checked against the ODE itself
    assert sp.simplify(nf.b - 1) == 0
    assert sp.simplify(nf.a - (-_tower(3) + sp.exp(sp.exp(sp.E)))) == 0


def test_the_grammar_refuses_an_exp_tower_from_a_config_string(tmp_path):
    from fl_design.symbolic._grammar import parse_expression

    names = {"x1": x1, "u": u}
    with pytest.raises(ExpressionError, match="MAX_EXP_NESTING = 3"):
        parse_expression("exp(" * 12 + "x1" + ")" * 12 + " + u", names)
    assert parse_expression("exp(exp(x1)) + x1**x1 + u", names) == sp.exp(sp.exp(x1)) + \
        x1**x1 + u


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="POSIX FIFOs")
def test_a_fifo_at_the_cache_key_is_refused_not_waited_on(tmp_path):
    code = ("import warnings, fl_design as fl\nwarnings.simplefilter('always')\n"
            "fl.plants.pendulum().normal_form()\nprint('done')")
    config = tmp_path / "config"
    (config / "fl_design").mkdir(parents=True, mode=0o700)
    os.chmod(config, 0o700)
    os.mkfifo(config / "fl_design" / "cache.key", 0o600)
    env = dict(os.environ, XDG_CONFIG_HOME=str(config), FL_DESIGN_CACHE=str(tmp_path / "c"))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, env=env, check=False)
    assert proc.returncode == 0 and "done" in proc.stdout, proc.stderr[-2000:]
    assert "is not a private 32-byte file" in proc.stderr


def test_an_overlong_plant_name_or_unit_is_refused_by_name():
    with pytest.raises(PlantDefinitionError, match="name has 201 characters, above the limit"):
        fl.Plant.from_ode([x1], u, [-x1 + u], x1, name="n" * 201)
    assert fl.Plant.from_ode([x1], u, [-x1 + u], x1, name="n" * 200).name == "n" * 200
    from fl_design.app import parse_config

    for key in ("name", "output_unit", "input_unit"):
        text = (f'[plant]\nstates = ["x1"]\ninput = "u"\nrhs = ["-x1 + u"]\noutput = "x1"\n'
                f'{key} = "{"m" * 300}"\n')
        with pytest.raises(ParameterError, match=f"{key} has 300 characters"):
            parse_config(text)


def test_stdout_shows_terminal_control_characters_as_escapes():
    from fl_design._streams import TolerantStream

    buf = io.StringIO()
    out = TolerantStream(buf, "stdout")
    assert out.write("p\x1b]0;title\x07\x1b[2J\r\x9b\tok\n") == 21
    assert buf.getvalue() == "p\\x1b]0;title\\x07\\x1b[2J\\x0d\\x9b\tok\n"
    err_buf = io.StringIO()
    TolerantStream(err_buf, "stderr").write("\rprogress")  # progress bars keep \r there
    assert err_buf.getvalue() == "\rprogress"


def test_derive_never_prints_a_terminal_escape_of_a_plant_name(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[plant]\nname = "p\\u001b]0;pwn\\u0007\\u001b[2J"\nstates = ["x1", "x2"]\n'
                   'input = "u"\nrhs = ["x2", "-x1 - x2 + u"]\noutput = "x1"\n')
    proc = subprocess.run([sys.executable, "-m", "fl_design", "derive", str(cfg)],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr[-1500:]
    assert "\x1b" not in proc.stdout and "\\x1b" in proc.stdout


def test_a_config_nested_thousands_deep_is_a_clear_error():
    from fl_design.app import parse_config
    from fl_design.app._config import ConfigError

    text = '[plant]\nlibrary = "pendulum"\n[sweep]\neps = ' + "[" * 5000 + "]" * 5000 + "\n"
    with pytest.raises(ConfigError, match="nested too deeply"):
        parse_config(text)


def test_the_report_is_written_by_name_never_into_a_folder_or_link_in_the_way(tmp_path):
    from fl_design.app import load_config, run_job, write_report
    from fl_design.errors import OutputPathError

    job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    out = tmp_path / "out"
    (out / "report.md").mkdir(parents=True)
    with pytest.raises(OutputPathError, match="report.md' is a folder, where fl_design writes"):
        write_report(job, out)
    victim = tmp_path / "victim.txt"
    victim.write_text("mine")
    (out / "report.md").rmdir()
    write_report(job, out)
    (out / "summary.json").unlink()
    (out / "summary.json").symlink_to(victim)
    write_report(job, out, force=True)
    assert victim.read_text() == "mine" and not (out / "summary.json").is_symlink()
    assert (out / "summary.json").read_text().startswith("{")
