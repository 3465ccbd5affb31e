"""Output folders never write through: links anywhere in the folder are refused (or, with
force, removed, never followed), a planted marker protects nothing, a second concurrent claim
fails clearly, a killed run's files are recognised, and a prefix naming a package file is
refused."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from fl_design import presets
from fl_design._output import (
    LOCK,
    MARKER,
    check_prefix_names,
    claim_output_folder,
    output_path,
    record_outputs,
    release_output_folder,
    write_output,
)
from fl_design.codegen import generate_c
from fl_design.errors import OutputExistsError, OutputPathError, ParameterError

pytestmark = pytest.mark.usefixtures("own_user_key")


def _ours(folder: Path, files: dict) -> Path:
    """A folder holding our own earlier output (claimed, written, recorded, released)."""
    claim_output_folder(folder)
    paths = []
    for rel, text in files.items():
        p = folder / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
        paths.append(p)
    record_outputs(folder, paths)
    return folder


def test_a_symlink_deep_in_our_output_is_refused_and_its_target_kept(tmp_path):
    out = _ours(tmp_path / "out", {"c/fl.c": "int x;", "runs/a.csv": "t\n"})
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    (out / "c" / "build").mkdir()
    (out / "c" / "build" / "sil.c").symlink_to(victim)
    (out / "runs" / "main_noise0.csv").symlink_to(victim)
    with pytest.raises(OutputExistsError, match=r"links or special files: c/build/sil.c, "
                                                r"runs/main_noise0.csv; .*never writes through"):
        claim_output_folder(out)
    assert victim.read_text() == "precious"
    assert not (out / LOCK).exists() or (out / LOCK).is_file()


def test_with_force_links_are_removed_never_followed(tmp_path):
    out = _ours(tmp_path / "out", {"report.md": "ours"})
    user = tmp_path / "user_folder"
    user.mkdir()
    (user / "keep.txt").write_text("mine")
    victim = tmp_path / "victim.md"
    victim.write_text("precious")
    (out / "report.md").unlink()
    (out / "report.md").symlink_to(victim)
    (out / "build").symlink_to(user, target_is_directory=True)
    folder = claim_output_folder(out, force=True)
    assert not (out / "report.md").exists() and not os.path.lexists(out / "build")
    (folder / "report.md").write_text("new report")  # a plain writer cannot write through now
    assert victim.read_text() == "precious" and (user / "keep.txt").read_text() == "mine"
    release_output_folder(folder)


def test_hard_links_and_fifos_are_refused(tmp_path):
    out = _ours(tmp_path / "out", {"a.txt": "x"})
    other = tmp_path / "elsewhere.txt"
    other.write_text("shared inode")
    os.link(other, out / "hard.txt")
    os.mkfifo(out / "report.html")
    with pytest.raises(OutputExistsError, match="hard.txt, report.html"):
        claim_output_folder(out)
    claim_output_folder(out, force=True)  # removes both names, never opens the FIFO
    assert other.read_text() == "shared inode" and not os.path.lexists(out / "report.html")
    release_output_folder(out)


def test_a_planted_marker_protects_nothing(tmp_path):
    proj = tmp_path / "proj"
    proj.mkdir()
    (proj / "Makefile").write_text("all:\n\techo mine\n")
    (proj / MARKER).write_text(json.dumps({"format": "fl_design output 1", "files": {}}))
    with pytest.raises(OutputExistsError, match="Makefile"):
        generate_c(presets.least_squares_design(9), proj)
    forged = {"format": "fl_design output 2", "files": {}, "open_since_ns": 0, "mac": "0" * 64}
    (proj / MARKER).write_text(json.dumps(forged))
    with pytest.raises(OutputExistsError, match="Makefile"):
        claim_output_folder(proj)
    assert (proj / "Makefile").read_text() == "all:\n\techo mine\n"


def test_a_marker_copied_from_our_own_folder_is_not_trusted_elsewhere(tmp_path):
    ours = _ours(tmp_path / "ours", {"Makefile": "all:\n"})
    proj = tmp_path / "proj"
    proj.mkdir()
    (proj / "Makefile").write_text("all:\n")  # same content, but not written there by us
    (proj / MARKER).write_bytes((ours / MARKER).read_bytes())
    with pytest.raises(OutputExistsError, match="Makefile"):
        claim_output_folder(proj)


def test_an_edited_file_is_protected_and_a_generated_one_is_not(tmp_path):
    out = _ours(tmp_path / "out", {"fl.c": "int x;"})
    release_output_folder(claim_output_folder(out))
    (out / "fl.c").write_text("int x; /* mine */")
    with pytest.raises(OutputExistsError, match="fl.c"):
        claim_output_folder(out)


HOLD = textwrap.dedent("""
    import sys, time
    from fl_design._output import claim_output_folder
    folder = claim_output_folder(sys.argv[1])
    (folder / "new.txt").write_text("written by the run")
    print("claimed", flush=True)
    if sys.argv[2] == "kill":
        import os
        os._exit(9)  # killed before recording anything
    time.sleep(30)
""")


def test_a_second_concurrent_claim_fails_clearly(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(out), "hold"],
                            stdout=subprocess.PIPE, text=True, env={**os.environ})
    try:
        assert proc.stdout.readline().strip() == "claimed"
        with pytest.raises(OutputPathError, match=rf"being written by another fl_design run "
                                                  rf"\(pid {proc.pid}"):
            claim_output_folder(out)
        with pytest.raises(OutputPathError, match="being written"):
            claim_output_folder(out, wait=0.3)
    finally:
        proc.kill()
        proc.wait(timeout=30)
    claim_output_folder(out)  # its lock died with it; its new file was its own
    release_output_folder(out)


def test_a_killed_runs_new_files_are_recognised(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-c", HOLD, str(out), "kill"], capture_output=True, check=False,
                          text=True, timeout=60, env={**os.environ})
    assert proc.returncode == 9 and (out / "new.txt").exists()
    claim_output_folder(out)
    release_output_folder(out)
    assert "new.txt" in json.loads((out / MARKER).read_text())["files"]


def test_write_output_replaces_a_link_and_refuses_leaving_the_folder(tmp_path):
    folder = claim_output_folder(tmp_path / "out")
    victim = tmp_path / "victim"
    victim.write_text("precious")
    (folder / "a.txt").symlink_to(victim)
    assert write_output(folder, "a.txt", "ours").read_text() == "ours"
    assert victim.read_text() == "precious" and not (folder / "a.txt").is_symlink()
    (folder / "sub").symlink_to(tmp_path, target_is_directory=True)
    with pytest.raises(OutputPathError, match="is a link or not a folder"):
        output_path(folder, "sub/x.c")
    for bad in ("../x", "/etc/passwd", MARKER):
        with pytest.raises(OutputPathError, match="not a file name inside"):
            write_output(folder, bad, "x")
    release_output_folder(folder)


@pytest.mark.parametrize("prefix", ["main", "Main", "MAIN"])
def test_a_prefix_naming_a_package_file_is_refused(prefix):
    fixed = ["main.c", "Makefile", "README.md", "CMakeLists.txt", "pil/pil_main.c"]
    with pytest.raises(ParameterError, match=rf"prefix='{prefix}' names main.c"):
        check_prefix_names(prefix, fixed)
    assert check_prefix_names("fl", fixed) == "fl"
