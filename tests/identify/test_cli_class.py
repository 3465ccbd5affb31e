"""The command line of the model-free route: init --class, run CLASS.toml, identify LOG.csv."""
import json

import pytest

from fl_design.app import main
from fl_design.app._class_table import parse_class_config
from fl_design.app._config import ConfigError

from .conftest import square, steps


def test_init_class_writes_a_config_run_accepts(capsys):
    assert main(["init", "--class"]) == 0
    text = capsys.readouterr().out
    cfg = parse_class_config(text)
    assert cfg.plant_class.b == (1.0, 50.0) and cfg.plant_class.rho == 2
    assert "# Optional bounds" in text


@pytest.mark.parametrize("body, match", [
    ("[class]\nrho = 2\nT = 1e-3\nb = [1.0, 50.0]\nwidth = 3", "unknown key 'width' in"),
    ("[class]\nrho = 2\nT = 1e-3\nb = [-1.0, 50.0]", r"\[class\] b = \(-1, 50\) contains 0"),
    ("[class]\nrho = 2\nT = 1e-3", r"\[class\] needs rho, T and b"),
    ("[class]\nrho = 2\nT = 1e-3\nb = [1, 2]\n[plant]\nlibrary = 'trms'", r"\[plant\] belongs"),
])
def test_bad_class_configs_name_table_and_key(body, match):
    with pytest.raises(ConfigError, match=match):
        parse_class_config(body)


def test_a_class_config_given_to_a_model_command_says_so(tmp_path, capsys):
    p = tmp_path / "c.toml"
    p.write_text("[class]\nrho = 2\nT = 1e-3\nb = [1.0, 2.0]\n")
    assert main(["certify", str(p)]) == 2
    assert "`fl-design run` designs from it" in capsys.readouterr().err


@pytest.mark.slow
def test_run_class_gives_report_certified_and_c_package(tmp_path, capsys):
    p = tmp_path / "class.toml"
    p.write_text("[class]\nrho = 2\nT = 1e-3\nb = [2.0, 10.0]\nnoise_std = 1e-3\n"
                 "u_limits = [-20.0, 20.0]\n[tune]\nreference = 1.0\n")
    out = tmp_path / "out"
    assert main(["run", str(p), "--quick", "--no-progress", "--out", str(out)]) == 0
    md = (out / "report.md").read_text()
    summary = md.split("\n## ")[1]
    assert "**certified**" in summary and "for every plant of the class" in summary
    assert "NOT" not in summary
    assert any(out.rglob("*.h")) and (out / "class_map.png").is_file()
    s = json.loads((out / "summary.json").read_text())
    assert s["tuning"]["certified"] and s["tuning"]["plant_class"]["b"] == [2, 10]
    assert "linear ADRC" in md
    assert capsys.readouterr().err == ""  # --no-progress: nothing on stderr


def test_run_class_says_each_step_on_stderr(tmp_path, capsys):
    """Without --no-progress every stage and each tuning step is a line, with the seconds so
    far, the candidates in the order they were tried."""
    p = tmp_path / "class.toml"
    p.write_text("[class]\nrho = 2\nT = 1e-3\nb = [2.0, 10.0]\nnoise_std = 1e-3\n"
                 "u_limits = [-20.0, 20.0]\n[tune]\nreference = 1.0\n")
    assert main(["run", str(p), "--quick", "--out", str(tmp_path / "out")]) == 0
    err = [x for x in capsys.readouterr().err.splitlines() if x.startswith("[fl-design]")]
    stages = [x.split()[1] for x in err if x.split()[1][:2] in ("1/", "2/", "3/", "4/")]
    assert stages == ["1/4", "2/4", "3/4", "4/4"]
    tune = [x for x in err if x.startswith("[fl-design] tune: ")]
    assert tune[0].startswith("[fl-design] tune: candidate 1/3, |gamma| |b|_max = 0.5: ")
    assert any("the class certificate" in x for x in tune)
    assert any("member runs" in x for x in tune)
    assert all(x.endswith(" s)") for x in err)


def test_identify_cli_writes_page_and_class_and_prints_the_command(tmp_path, capsys,
                                                                   narrow_design):
    from fl_design.sim._rig import chain_rig

    log = chain_rig(2, b=4.0, T=1e-3, noise_std=1e-3).run(
        narrow_design, steps(2.0), 10.0, excitation=square(0.125, 0.5))
    csv = log.write_csv(tmp_path / "rig.csv")
    out = tmp_path / "id"
    assert main(["identify", str(csv), "--rho", "2", "--u-limits", "-20", "20",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"fl-design run {out / 'class.toml'}" in printed
    cfg = parse_class_config((out / "class.toml").read_text())
    assert cfg.plant_class.b[0] <= 4.0 <= cfg.plant_class.b[1]
    assert cfg.plant_class.u_limits == (-20.0, 20.0) and cfg.plant_class.source == "log"
    assert (out / "identify.html").is_file()


def test_identify_cli_bad_log_is_one_line_exit_2(tmp_path, capsys):
    p = tmp_path / "bad.csv"
    p.write_text("time,y,u\n" + "\n".join(f"{i * 1e-3},0,{i % 3}" for i in range(500)))
    assert main(["identify", str(p), "--rho", "2", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "misses the column(s) 't'" in err and "Traceback" not in err
