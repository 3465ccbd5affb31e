"""`fl-design codegen CONFIG --out fl_c --verify` writes the package in fl_c itself, as without
--verify: the firmware guide's next command is `make -C fl_c check` (it found no Makefile: the
package was in fl_c/c)."""
import shutil
import subprocess

import pytest

from fl_design.app import _cli


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_codegen_verify_puts_the_package_in_out_and_make_check_passes(tmp_path):
    out = tmp_path / "fl_c"
    assert _cli.main(["codegen", "--plant", "pendulum", "--out", str(out), "--precision",
                      "float", "--verify", "--quick", "--no-progress"]) == 0
    assert (out / "Makefile").is_file() and (out / "fl.c").is_file()
    assert not (out / "c").exists()
    done = subprocess.run(["make", "-C", str(out), "check"], capture_output=True, text=True,
                          check=False,
                          timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "PASS" in done.stdout
