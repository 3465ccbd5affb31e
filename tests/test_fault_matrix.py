"""verify/fault_matrix.py --quick: bad inputs and environment faults in subprocesses, classified."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_fault_matrix_quick_has_no_raw_traceback_crash_or_hang(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    proc = subprocess.run([sys.executable, str(ROOT / "verify" / "fault_matrix.py"), "--quick",
                           "-v"], capture_output=True, text=True, timeout=300, check=False,
                          env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    rows = {m[0]: list(map(int, m[1:])) for m in re.findall(
        r"^(input|env)\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)$", proc.stdout, re.MULTILINE)}
    clear, result, raw, crash, hang, _skipped = rows["input"]
    assert clear >= 6 and result == 0 and raw + crash + hang == 0
    clear, result, raw, crash, hang, _skipped = rows["env"]
    assert result == 2 and raw + crash + hang == 0
    assert "OK: no raw traceback, crash or hang" in proc.stdout
    assert re.search(r"result\s+env\s+cache: truncated library", proc.stdout)
