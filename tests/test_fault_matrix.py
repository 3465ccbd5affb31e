"""verify/fault_matrix.py --quick: bad inputs and environment faults in subprocesses, classified."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_fault_matrix_quick_has_no_exec_loss_false_diagnosis_raw_crash_or_hang(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    proc = subprocess.run([sys.executable, str(ROOT / "verify" / "fault_matrix.py"), "--quick",
                           "-v"], capture_output=True, text=True, timeout=600, check=False,
                          env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    rows = {kind: list(map(int, numbers.split())) for kind, numbers in re.findall(r"^(input|env)((?:\s+\d+){10})$", proc.stdout, re.MULTILINE)}
    names = ("clear", "result", "exec", "lost", "falsediag", "silent", "raw", "crash", "hang",
             "skipped")
    inputs, envs = (dict(zip(names, rows[k])) for k in ("input", "env"))
    for row in (inputs, envs):
        assert all(row[c] == 0 for c in names[2:9]), proc.stdout
    assert inputs["clear"] >= 15 and inputs["result"] >= 1  # a badly scaled plant must run
    assert envs["result"] >= 3 and envs["clear"] >= 4
    assert "OK: no code executed, file lost" in proc.stdout
    assert re.search(r"result\s+env\s+cache: truncated library", proc.stdout)
    assert re.search(r"clear\s+input\s+string rhs: __import__ os.system", proc.stdout)
    assert re.search(r"clear\s+env\s+output: codegen \. in a project", proc.stdout)
    assert re.search(r"result\s+env\s+cache: planted pickles", proc.stdout)
    # issue 36: a cache folder carrying its own key, write-through, bounds, streams
    assert re.search(r"result\s+env\s+cache: a folder carrying its own key", proc.stdout)
    assert re.search(r"clear\s+env\s+output: symlink at c/build/sil.c", proc.stdout)
    assert re.search(r"clear\s+env\s+output: planted marker in a project", proc.stdout)
    assert re.search(r"clear\s+input\s+bounds: \(x1 \+ x2 \+ u\)\*\*1000 - x1", proc.stdout)
    assert re.search(r"result\s+input\s+structure: -x1 \+ u \+ u\*\*40", proc.stdout)
    assert re.search(r"clear\s+env\s+raw: stdout closed", proc.stdout)
    # held-out variants (verify/fault_cases_heldout.py)
    assert re.search(r"result\s+env\s+held-out cache: two valid entries swapped", proc.stdout)
    assert re.search(r"clear\s+env\s+held-out output: unsigned marker with the user's true "
                     r"hashes", proc.stdout)
    assert re.search(r"result\s+input\s+held-out markup: a name closing the report's code "
                     r"fence", proc.stdout)
    assert re.search(r"clear\s+input\s+held-out bounds: 2\*\*2\*\*2", proc.stdout)
    assert re.search(r"result\s+input\s+held-out structure: -x1 \+ 2\*u \+ u\*\*3", proc.stdout)
    assert re.search(r"clear\s+input\s+held-out structure: fi and the ligature", proc.stdout)
    assert re.search(r"result\s+input\s+held-out structure: a 0.05 s run is undecided",
                     proc.stdout)
    assert re.search(r"clear\s+env\s+held-out waits: a worker killed mid-map keeps a partial "
                     r"map: WorkerLostError", proc.stdout)
