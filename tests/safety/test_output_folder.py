"""Never overwrite what we did not write: generate_c, run --out, codegen DIR and the report
write into an empty folder or one holding our own unchanged output, else refuse (exit 2)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fl_design import presets
from fl_design._output import MARKER, claim_output_folder, record_outputs
from fl_design.app import load_config, run_job, write_report
from fl_design.codegen import generate_c
from fl_design.errors import OutputExistsError, OutputPathError

ROOT = Path(__file__).resolve().parents[2]
PROJECT = {"Makefile": "all:\n\techo mine\n", "README.md": "# my project\n",
           "main.c": "int main(void) { return 0; }\n"}


def _project(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in PROJECT.items():
        (folder / name).write_text(text)
    return folder


def _unchanged(folder: Path) -> bool:
    return all((folder / n).read_text() == t for n, t in PROJECT.items())


@pytest.fixture(scope="module")
def design():
    return presets.least_squares_design(9)


def test_generate_c_refuses_a_project_folder_and_keeps_its_files(tmp_path, design):
    folder = _project(tmp_path / "proj")
    with pytest.raises(OutputExistsError, match=r"Makefile, README.md, main.c; .*force=True"):
        generate_c(design, folder)
    assert _unchanged(folder) and not (folder / "fl.c").exists()


def test_generate_c_with_force_writes_there(tmp_path, design):
    folder = _project(tmp_path / "proj")
    pkg = generate_c(design, folder, force=True)
    assert (folder / "fl.c").exists() and (folder / "Makefile").read_text() != PROJECT["Makefile"]
    assert all((folder / p.resolve().relative_to(folder.resolve())).is_file() for p in pkg.files)
    assert any(p.parent.name == "pil" for p in pkg.files)  # the PIL files, in a subfolder


def test_an_edited_file_in_a_subfolder_of_our_output_is_protected(tmp_path, design):
    folder = tmp_path / "c"
    generate_c(design, folder)
    edited = folder / "pil" / "pil_main.c"
    edited.write_text(edited.read_text() + "\n/* my board */\n")
    with pytest.raises(OutputExistsError, match="pil/pil_main.c"):
        generate_c(design, folder)


def test_generate_c_again_into_its_own_output_is_fine_until_a_file_is_edited(tmp_path, design):
    folder = tmp_path / "c"
    first = generate_c(design, folder)
    second = generate_c(design, folder)  # unchanged earlier output: replaced
    assert [p.name for p in first.files] == [p.name for p in second.files]
    (folder / "fl.c").write_text((folder / "fl.c").read_text() + "\n/* my fix */\n")
    with pytest.raises(OutputExistsError, match=r"changed since: fl.c;"):
        generate_c(design, folder)
    assert (folder / "fl.c").read_text().endswith("/* my fix */\n")


def test_an_empty_folder_and_a_new_one_are_fine(tmp_path):
    (tmp_path / "empty").mkdir()
    assert claim_output_folder(tmp_path / "empty").is_dir()
    assert claim_output_folder(tmp_path / "a" / "b").is_dir()
    assert (tmp_path / "a" / "b" / MARKER).is_file()


@pytest.mark.parametrize("bad", ["", "   ", None, 3])
def test_no_path_is_a_clear_error(bad):
    with pytest.raises(OutputPathError, match="empty or not a path"):
        claim_output_folder(bad)


def test_a_file_in_place_of_the_folder_is_refused(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(OutputPathError, match="exists and is not a folder"):
        claim_output_folder(tmp_path / "f")


def test_a_garbled_marker_counts_as_none(tmp_path):
    folder = claim_output_folder(tmp_path / "o")
    (folder / "a.txt").write_text("ours")
    record_outputs(folder, [folder / "a.txt"])
    (folder / MARKER).write_text("{not json")
    with pytest.raises(OutputExistsError, match="a.txt"):
        claim_output_folder(folder)


def test_the_report_refuses_a_foreign_folder(tmp_path):
    folder = _project(tmp_path / "proj")
    job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    with pytest.raises(OutputExistsError, match="report folder"):
        write_report(job, folder)
    assert _unchanged(folder) and not (folder / "report.html").exists()
    paths = write_report(job, tmp_path / "rep")
    assert write_report(job, tmp_path / "rep") == paths  # our own earlier report: replaced


def _cli(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "fl_design", *args], capture_output=True,
                          text=True, cwd=cwd, env=env, timeout=300, check=False)


@pytest.mark.parametrize("args", [("codegen", "."), ("run", "--quick", "--out", ".")])
def test_cli_refuses_with_one_line_exit_2_before_work(tmp_path, args):
    folder = _project(tmp_path / "proj")
    proc = _cli(*args, cwd=folder)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "--force" in lines[0] and "Makefile" in lines[0], proc.stderr
    assert "1/5" not in proc.stderr
    assert _unchanged(folder) and sorted(os.listdir(folder)) == sorted(PROJECT)


def test_cli_codegen_with_force_writes(tmp_path):
    folder = _project(tmp_path / "proj")
    proc = _cli("codegen", ".", "--force", "--design", "ls9", cwd=folder)
    assert proc.returncode == 0, proc.stderr
    assert (folder / "fl.c").exists() and not _unchanged(folder)
