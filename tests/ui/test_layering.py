"""Nothing imports the tuner but the command line, and the tuner does not import ``app``
(the command line hands it a TunerSetup): no import circle, library layers untouched."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "fl_design"


def _imports(path: Path) -> set[str]:
    pkg = ".".join(("fl_design", *path.relative_to(ROOT).parts[:-1]))
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out |= {mod} | {f"{mod}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
    return out


def test_only_the_cli_imports_the_tuner():
    users = sorted(str(p.relative_to(ROOT)) for p in ROOT.rglob("*.py")
                   if "ui" not in p.relative_to(ROOT).parts[:1]
                   and any(m == "fl_design.ui" or m.startswith("fl_design.ui.")
                           for m in _imports(p)))
    assert users == ["app/_cli.py"], users


def test_the_tuner_does_not_import_app():
    bad = {str(p.relative_to(ROOT)): sorted(m for m in _imports(p)
                                            if m.startswith("fl_design.app"))
           for p in (ROOT / "ui").rglob("*.py")}
    assert not any(bad.values()), bad
