"""Nothing imports the tuner but the command line, and the tuner does not import ``app``
(the command line hands it a TunerSetup): no import circle, library layers untouched."""

from __future__ import annotations

from tests.source_imports import ROOT, imported_names


def test_only_the_cli_imports_the_tuner():
    users = sorted(str(p.relative_to(ROOT)) for p in ROOT.rglob("*.py")
                   if "ui" not in p.relative_to(ROOT).parts[:1]
                   and any(m == "fl_design.ui" or m.startswith("fl_design.ui.")
                           for m in imported_names(p)))
    assert users == ["app/_cli.py"], users


def test_the_tuner_does_not_import_app():
    bad = {str(p.relative_to(ROOT)): sorted(m for m in imported_names(p)
                                            if m.startswith("fl_design.app"))
           for p in (ROOT / "ui").rglob("*.py")}
    assert not any(bad.values()), bad
