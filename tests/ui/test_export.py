"""The page's buttons: a TOML that reads back to the same design, a C package, a snippet that
reproduces the response; all under the no-overwrite rule."""

from __future__ import annotations

import subprocess
import sys

import pytest

from fl_design.app import parse_config
from fl_design.errors import OutputExistsError
from fl_design.ui._export import save_snippet, save_toml, write_c


def test_saved_toml_reads_back_to_the_tuned_design(trms_tuner, tmp_path):
    v = trms_tuner.defaults() | {"gamma": 1e-3, "eps": 0.08, "gains": [3.0, 5.0],
                                  "reference": 0.25, "duration": 12.0}
    path = save_toml(trms_tuner, v, tmp_path / "out")
    cfg = parse_config(path.read_text(), source=str(path))
    assert (cfg.design.gamma, cfg.design.eps, cfg.design.gains) == (1e-3, 0.08, (3.0, 5.0))
    assert (cfg.scenario.reference, cfg.scenario.duration) == (0.25, 12.0)
    again = save_toml(trms_tuner, v, tmp_path / "out")  # a new name: nothing replaced
    assert (path.name, again.name) == ("design_1.toml", "design_2.toml")


def test_a_folder_holding_other_files_is_refused(trms_tuner, tmp_path):
    (tmp_path / "mine.txt").write_text("not fl_design's")
    with pytest.raises(OutputExistsError, match="mine.txt"):
        save_toml(trms_tuner, {}, tmp_path)
    assert (tmp_path / "mine.txt").read_text() == "not fl_design's"


def test_c_package_goes_into_a_new_folder(trms_tuner, tmp_path):
    pkg = write_c(trms_tuner, {"gamma": 1e-3}, tmp_path)
    assert pkg.out_dir.name == "c_1" and pkg.design.controller.gamma == 1e-3
    assert write_c(trms_tuner, {}, tmp_path).out_dir.name == "c_2"


def test_snippet_reproduces_the_page_verdict(trms_tuner, tmp_path):
    v = {"gamma": 0.0006013416082095486, "eps": 0.0512345678901, "duration": 6.0}
    view = trms_tuner.redraw(v)
    path, text = save_snippet(trms_tuner, v, tmp_path)
    assert path.read_text() == text
    run = text.replace("resp.plot()\n", "")  # no figure in a test
    out = subprocess.run([sys.executable, "-c", run], capture_output=True, text=True,
                         timeout=240, check=True, cwd=tmp_path)
    assert out.stdout.strip() == view["verdict"]["text"]
    assert "gamma=0.0006013416082095486" in text  # every digit: the same run, not a rounding
