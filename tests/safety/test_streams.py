"""No raw traceback from a closed, full or ASCII-only standard output: one line, exit 2 when
the printed text was lost, backslash escapes on an ASCII terminal."""

from __future__ import annotations

import io
import os
import subprocess
import sys

import pytest

from fl_design._streams import TolerantStream

PLANT = """[plant]
name = "Pendel \u03b8 m\u00fcde"
states = ["th", "om"]
input = "u"
rhs = ["om", "-9.81*sin(th) - 0.5*om + u"]
output = "th"
"""


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text(PLANT, encoding="utf-8")
    return str(path)


def _derive(config, stdout, env=None):
    return subprocess.run([sys.executable, "-m", "fl_design", "derive", config], stdout=stdout,
                          stderr=subprocess.PIPE, text=True, timeout=240, check=False,
                          env={**os.environ, **(env or {})})


def test_a_closed_stdout_is_one_line_and_exit_2(config):
    proc = subprocess.run(f'"{sys.executable}" -m fl_design derive "{config}" >&-', shell=True,
                          stderr=subprocess.PIPE, text=True, timeout=240, check=False)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    expected = ("fl-design: error: standard output could not be written (it is closed): the "
                "printed text was lost; the command's files were written")
    assert proc.stderr.strip().splitlines() == [expected]


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_a_full_stdout_is_one_line_and_exit_2(config):
    with open("/dev/full", "w") as full:
        proc = _derive(config, full)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "No space left on device" in proc.stderr and len(proc.stderr.splitlines()) == 1


def test_an_ascii_only_stdout_gets_escapes(config):
    proc = _derive(config, subprocess.PIPE, env={"PYTHONIOENCODING": "ascii"})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0] == "Plant: Pendel \\u03b8 m\\xfcde"


def test_the_tolerant_stream_records_the_first_failure():
    class Full(io.StringIO):
        def write(self, text):
            raise OSError(28, "No space left on device")

    out = TolerantStream(Full(), "stdout")
    assert out.write("a") == 1 and out.failed == "No space left on device"
    out.write("b")
    assert out.failed == "No space left on device"
    with pytest.raises(BrokenPipeError):
        class Pipe(io.StringIO):
            def write(self, text):
                raise BrokenPipeError
        TolerantStream(Pipe(), "stdout").write("x")
