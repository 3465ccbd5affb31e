"""The command line: the main job in quick mode, each sub-command, and its one-line errors."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fl_design.app import main
from fl_design.app._report_render import md as escaped

ROOT = Path(__file__).resolve().parents[2]


def _cli(*args, cwd=None, timeout=120):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "fl_design", *args], capture_output=True,
                          text=True, cwd=cwd, env=env, timeout=timeout, check=False)


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    proc = _cli("run", "--quick", "--out", str(out), timeout=300)
    assert proc.returncode == 0, proc.stderr
    return out, proc


def test_run_writes_report_with_sections_and_embedded_figures(quick_run):
    out, _ = quick_run
    html = (out / "report.html").read_text()
    md = (out / "report.md").read_text()
    order = ["Summary", "Simulations: this design and the paper&#x27;s comparison",
             "Stability map and eps*", "Certificates", "C code", "Derivation"]
    where = [html.index(f">{section}</h2>") for section in order]
    assert where == sorted(where)  # the answers first, the derivation last
    # the summary links every answer to its section, and those ids exist
    summary = html[where[0]:where[1]]
    for target in re.findall(r'href="#([a-z0-9-]+)"', summary):
        assert f'<h2 id="{target}">' in html
    for question in ("Plant", "Does it work?", "Certified", "Generated C"):
        assert question in summary
    assert "operating point x_op = (" in summary and "u_eq = " in summary
    assert "SIL PASSED" in summary or "SIL FAILED" in summary
    assert "<math>" in html and "$$" in md  # the maths rendered (MathML, LaTeX)
    assert md.index("## Summary") < md.index("## Derivation")
    for name in ("stability_map.png", "eps_star.png", "steps.png", "noise_tradeoff.png",
                 "response.png"):
        assert (out / name).stat().st_size > 10_000
        assert f"]({name})" in md
    assert len(re.findall(r'<img [^>]*src="data:image/png;base64,', html)) == 5
    assert "<img" in html and 'src="stability_map.png"' not in html  # self-contained
    # the certificates certify the TRMS's class (slope box, b range): brackets frozen, nonlinear
    assert "P_x =" in md and escaped("eps* for nonlinear b (s): [certified, refuted]") in md
    assert "Software in the loop" in md


def test_summary_is_strict_json_with_verdicts(quick_run):
    out, _ = quick_run
    text = (out / "summary.json").read_text()
    data = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-strict JSON {c}"))
    assert data["derivation"]["rho"] == 2
    assert data["derivation"]["b_bounds"] == pytest.approx([3.6, 6.8])
    runs = data["simulate"]["runs"]
    assert {r["design"] for r in runs} == {"EHGO eps=0.05", "LS(9)", "LS(26)"}
    assert all(r["status"] in ("converged", "converging", "oscillating", "stalled", "undecided", "diverged")
               for r in runs)
    assert data["codegen"]["sil"]["passed"] is True
    # the TRMS's class (friction slope box [-505, -5], b in [3.6, 6.8]) is not certified: a
    # switching of the friction slope grows; summary.json names the class it certifies
    eps = data["certify"]["eps"]
    assert eps["certified"] is False and eps["plant_class"]["source"] == "plant"
    assert eps["class_description"].startswith("class of plant 'trms_yaw'")
    # linearized eps*: a bracket per gamma, "> top" when stable on the whole range, never NaN
    lin = data["certify"]["linearized"]
    top = lin["eps_range"][1]
    for star in [*lin["eps_star"], data["certify"]["linearized_design"]]:
        assert set(star) == {"lower", "upper", "upper_status", "text"}
        assert star["upper_status"] is None  # a linearization has no run status
        if star["upper"] is None:
            assert star["lower"] == top and star["text"] == f"> {top:g}"
        else:
            assert star["lower"] < star["upper"]


def test_progress_goes_to_stderr_only(quick_run):
    _, proc = quick_run
    assert "[fl-design]" in proc.stderr and "[fl-design]" not in proc.stdout
    assert "trms_yaw: EHGO eps = 0.05 s" in proc.stdout and "Does it work?" in proc.stdout


def test_default_console_fits_one_screen_and_verbose_gives_the_detail(quick_run, capsys):
    """The default stdout is the summary (<= 60 lines, each answer <= 25 words); --verbose
    adds every stage's detail (the derivation, the certificates, the map)."""
    _, proc = quick_run
    lines = proc.stdout.splitlines()
    assert len(lines) <= 60, len(lines)
    answers = lines[1:lines.index("")]
    assert len(answers) >= 7 and all(len(line.split()) <= 2 + 25 + 4 for line in answers)
    assert "LyapunovCertificate" not in proc.stdout and "--verbose" in proc.stdout
    from fl_design.app import load_config, run_job
    from fl_design.app._console import print_job

    job = run_job(load_config(None), quick=True, stages=("certify",), progress=False)
    print_job(job, verbose=True)
    verbose = capsys.readouterr().out
    print_job(job)
    short = capsys.readouterr().out
    assert "LyapunovCertificate" in verbose and "Plant: trms_yaw" in verbose
    assert verbose.endswith(short) and len(verbose) > 2 * len(short)


@pytest.mark.parametrize("text,needle", [
    ("[design]\nepsilon = 0.1\n", "unknown key 'epsilon' in [design]"),
    ("[design]\neps = 'small'\n", "[design] eps must be a real number, got 'small'"),
    ("[plantt]\n", "unknown table [plantt]"),
    ("[design]\neps = \n", "not valid TOML"),
    ("[plant]\nstates = ['x']\n", "needs 'input'"),
    ("[sweep]\npoints = 1\n", "[sweep] points must be >= 2"),
    ("[design]\ngains = [1, 2, 3]\n", "relative degree 2"),
])
def test_bad_config_is_one_line_exit_2_before_work(tmp_path, text, needle):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    proc = _cli("run", str(cfg), "--out", str(tmp_path / "o"))
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in proc.stderr
    assert not (tmp_path / "o" / "report.html").exists()


@pytest.mark.parametrize("out", ["/dev/null/x", ""])
def test_unwritable_or_empty_out_exits_2_before_work(out):
    proc = _cli("run", "--out", out, timeout=60)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and "--out" in proc.stderr
    assert "[fl-design] 1/5" not in proc.stderr  # no stage started


def test_missing_config_file(tmp_path):
    proc = _cli("run", str(tmp_path / "nope.toml"))
    assert proc.returncode == 2 and "cannot read config" in proc.stderr


def test_closed_pipe_is_one_line(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run(f"{sys.executable} -m fl_design derive --plant flexible-joint --latex"
                          " | head -1", shell=True, capture_output=True, text=True, env=env,
                          timeout=60, check=False)
    assert "Traceback" not in proc.stderr
    assert proc.stdout.startswith("Plant: flexible_joint")


def test_version_and_help():
    assert _cli("--version").stdout.startswith("fl-design 0.1.0")
    for sub in ("run", "derive", "certify", "simulate", "sweep", "codegen"):
        proc = _cli(sub, "--help")
        assert proc.returncode == 0 and "--quick" in proc.stdout


def test_derive_prints_relative_degree_and_b_range(capsys):
    assert main(["derive", "--plant", "trms"]) == 0
    out = capsys.readouterr().out
    assert "relative degree rho = 2" in out
    assert "b-range over the region: [3.6, 6.8]" in out
    assert "x1         T**3*sigma_dot/6           3           3" in out


def test_derive_latex_for_flexible_joint(capsys):
    assert main(["derive", "--plant", "flexible-joint", "--latex"]) == 0
    out = capsys.readouterr().out
    assert "relative degree rho = 4" in out and "LaTeX F^a: \\left[" in out


def test_unknown_plant_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["derive", "--plant", "cartpole"])
    assert exc.value.code == 2
    assert "invalid choice: 'cartpole'" in capsys.readouterr().err


def test_simulate_and_sweep_subcommands_alone(capsys):
    assert main(["simulate", "--quick", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert out.count("EHGO eps=0.05") == 3 and "LS(26)" in out
    assert main(["sweep", "--quick", "--no-progress", "--plant", "pendulum"]) == 0
    assert "Stability map 5 x 5" in capsys.readouterr().out


def test_pendulum_example_config_runs_derive_and_certify(capsys):
    assert main(["certify", str(ROOT / "examples" / "pendulum.toml"), "--quick",
                 "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "GammaCertificate" in out and "pendulum" in out


def test_bad_scheduler_address_is_one_line():
    """The command line in a process of its own, as ``python -m fl_design`` runs it, with the
    scheduler's connect limit at 1 s instead of 10 s (the wait itself is bounded and tested in
    tests/safety/test_waits.py; here what the user reads)."""
    code = ("import sys\n"
            "from fl_design.sim import _scheduler\n"
            "_scheduler.connect_scheduler.__kwdefaults__['timeout'] = 1.0\n"
            "from fl_design.app._cli import main\n"
            "sys.exit(main(sys.argv[1:]))\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-c", code, "sweep", "--quick", "--scheduler",
                           "tcp://127.0.0.1:9"], capture_output=True, text=True, env=env,
                          timeout=120, check=False)
    assert proc.returncode == 2 and "Dask scheduler" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "Traceback" not in proc.stderr


def test_python_dash_m_entry_point(tmp_path):
    proc = _cli("derive", "--plant", "pendulum", cwd=tmp_path)
    assert proc.returncode == 0 and "Plant: pendulum" in proc.stdout


@pytest.mark.parametrize("name", ["cart-pendulum", "maglev"])
def test_every_library_plant_is_a_config_and_cli_name(name, capsys):
    """The plants added to the library are reachable from the command line; for the maglev
    (b < 0) the paper's gain bound is on |gamma|, 1/max|b| from its b-range."""
    import fl_design as fl

    assert main(["derive", "--plant", name]) == 0
    out = capsys.readouterr().out
    plant = {"cart-pendulum": fl.plants.cart_pendulum, "maglev": fl.plants.maglev}[name]()
    lo, hi = plant.b_bounds()
    assert f"relative degree rho = {plant.relative_degree()}" in out
    if hi < 0:
        assert f"|gamma| < 1/max|b| = {1 / abs(lo):.4g} (gamma < 0, as b)" in out
    else:
        assert f"gamma < 1/b_max = {1 / hi:.4g}" in out


def test_run_writes_the_compared_runs_as_csv(quick_run):
    """Every compared run beside the report (the main run only with --main-csv: tested in
    tests/app/test_report_csv.py), reading back to its summary's runs."""
    out, proc = quick_run
    data = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    files = sorted((out / "runs").glob("*.csv"))
    assert len(files) == len(data["simulate"]["runs"])
    assert not list((out / "runs").glob("main_*.csv"))
    assert "runs as CSV under" in proc.stdout
    table = np.genfromtxt(out / "runs" / "LS9_noise0.001.csv", delimiter=",", names=True)
    assert table.dtype.names[:5] == ("t", "r", "y", "ym", "u")
    assert np.all(np.diff(table["t"]) > 0) and table["r"][-1] == pytest.approx(0.3)
