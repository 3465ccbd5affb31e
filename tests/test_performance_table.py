"""The README's performance table: benchmarks record their targets (``verify/_shared.py``
``target``) and ``docs/generate.py`` turns the records into the table between two markers."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def shared(monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "verify"))
    return _load("_shared_under_test", ROOT / "verify" / "_shared.py")


@pytest.fixture
def generate(tmp_path, monkeypatch):
    gen = _load("generate_under_test", ROOT / "docs" / "generate.py")
    monkeypatch.setattr(gen, "TARGETS", tmp_path / "targets")
    monkeypatch.setattr(gen, "ROOT", tmp_path)
    (tmp_path / "targets").mkdir()
    return gen


def test_a_target_is_judged_and_recorded_only_when_asked(shared, tmp_path, monkeypatch):
    monkeypatch.delenv(shared.TARGETS_ENV, raising=False)
    assert shared.target("t", 4.0, 5.0) and not shared.target("t", 6.0, 5.0)
    assert shared.target("ratio", 2.6, 2.5, unit="x", at_least=True)
    assert not shared.target("ratio", 2.4, 2.5, unit="x", at_least=True)
    assert not list(tmp_path.iterdir())  # no file named: nothing written
    out = tmp_path / "bench.jsonl"
    monkeypatch.setenv(shared.TARGETS_ENV, str(out))
    monkeypatch.setattr(sys, "argv", ["verify/bench_x.py"])
    shared.target("cold job", 12.5, 15.0, detail="median of 3 round(s)")
    shared.target("map warm", 3.0, 2.5, checked=False)
    recs = [json.loads(line) for line in out.read_text().splitlines()]
    assert [(r["name"], r["met"], r["checked"], r["script"]) for r in recs] == [
        ("cold job", True, True, "bench_x"), ("map warm", False, False, "bench_x")]
    assert recs[0]["cores"] >= 1 and recs[0]["isa"] and recs[0]["cpu"]


def test_the_table_says_met_missed_and_not_checked_and_skips_bad_lines(shared, generate,
                                                                        monkeypatch, capsys):
    out = generate.TARGETS / "bench_x.jsonl"
    monkeypatch.setenv(shared.TARGETS_ENV, str(out))
    monkeypatch.setattr(sys, "argv", ["bench_x.py"])
    shared.target("fast", 1.0, 5.0)
    shared.target("slow", 9.0, 5.0)
    shared.target("ratio", 2.9, 2.5, unit="x", at_least=True, checked=False)
    with out.open("a") as f:
        f.write('__import__("os").system("false")\n{"name": "no other field"}\n')
    shared.target("a | b", 1234.5, 5000.0, unit="B")  # a pipe in a name, a large number
    table = generate.targets_table()
    lines = table.splitlines()
    assert lines[0].startswith("Measured on ") and "cores, kernel ISA" in lines[0]
    rows = lines[lines.index("| --- | --- | --- | --- | --- |") + 1:]
    assert len(rows) == 4 and all(r.count(" | ") == 4 for r in rows)
    assert rows[0].startswith("| fast | 1 s | <= 5 s | met | `bench_x`, load ")
    assert "| slow | 9 s | <= 5 s | **missed** |" in rows[1]
    assert "| ratio | 2.9x | >= 2.5x | not checked |" in rows[2]
    assert rows[3].startswith("| a \\| b | 1,234 B | <= 5,000 B | met |")
    assert capsys.readouterr().err.count("not a target record, skipped") == 2


def test_the_readme_table_replaces_only_what_lies_between_its_markers(generate):
    readme = generate.ROOT / "README.md"
    before = f"# title\n\ntext\n{generate.README_BEGIN}\nold table\n{generate.README_END}\nend\n"
    readme.write_text(before)
    assert generate.readme_table("| new |\n") == "wrote the performance table in README.md"
    assert readme.read_text() == before.replace("old table\n", "| new |\n")
    readme.write_text("# no markers\n")
    assert "left as it was" in generate.readme_table("| new |\n")
    assert readme.read_text() == "# no markers\n"
