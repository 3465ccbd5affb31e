"""The repository's root holds the product's parts only: no doctest or run output committed.

Doctests that write a C package or a report into the working directory, run from the root,
leave folders there (``bench_doc/``, ``report/``...); twice a ``git add -A`` committed them.
"""

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: What the root may hold (the guide's "product in one breath", the CI script, git's own file).
ALLOWED = {".ci", ".gitignore", "Makefile", "README.md", "derivations", "docs", "examples",
           "fl_design", "pyproject.toml", "tests", "verify"}


def test_only_the_products_parts_are_tracked_at_the_root():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout (or no git): nothing tracked to check")
    proc = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                          timeout=60, check=False)
    if proc.returncode != 0:
        pytest.skip(f"git ls-files failed: {proc.stderr.strip()[:200]}")
    top = {line.split("/", 1)[0] for line in proc.stdout.splitlines() if line}
    assert top, "git ls-files listed nothing"
    assert top <= ALLOWED, f"unexpected at the root: {sorted(top - ALLOWED)}"
