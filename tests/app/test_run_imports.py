"""A warm ``fl-design run`` of a library plant imports no SymPy (0.3-0.6 s of every process):
the plant loads from its recipe's cache, the derivation stage from the stage cache."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

_RUN = """
import json, sys
from fl_design.app import main
code = main(["run", "--quick", "--no-progress", "--out", sys.argv[1], "--force"])
print(json.dumps({"code": code, "sympy": "sympy" in sys.modules}))
"""


def test_a_warm_run_of_the_trms_does_not_import_sympy(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    seen = []
    for _ in range(2):  # the first run may fill the caches; the second loads them
        proc = subprocess.run([sys.executable, "-c", _RUN, str(tmp_path / "out")],
                              capture_output=True, text=True, env=env, timeout=600, check=False)
        assert proc.returncode == 0, proc.stderr
        seen.append(json.loads(proc.stdout.splitlines()[-1]))
    assert seen[-1] == {"code": 0, "sympy": False}
    assert (tmp_path / "out" / "report.html").is_file()
