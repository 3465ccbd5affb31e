"""The main job's cost table reuses rows measured earlier (compare_costs(cache=True)) only
when everything they depend on is the same, from the private cache, verified."""

from __future__ import annotations

import pytest

from fl_design import presets
from fl_design._cache import cache_directory
from fl_design._toolchain import find_compiler
from fl_design.codegen import compare_costs, generate_c
from fl_design.codegen._cost import cost_key

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "cache"))
    return tmp_path


def test_second_table_is_read_back_equal_and_a_change_measures_again(private_cache):
    designs = {"EHGO": presets.paper_design(), "LS(9)": presets.least_squares_design(9)}
    first = compare_costs(designs, private_cache / "a", bench_steps=1000, cache=True)
    assert first.cached == 0
    again = compare_costs(designs, private_cache / "b", bench_steps=1000, cache=True)
    assert again.cached == 2 and again.to_dict()["rows"] == first.to_dict()["rows"]
    assert again.to_markdown() == first.to_markdown()
    # another timing length or another design: measured, not read
    assert compare_costs(designs, private_cache / "c", bench_steps=2000, cache=True).cached == 0
    other = {"EHGO": presets.paper_design().replace(eps=0.04)}  # other generated code
    assert compare_costs(other, private_cache / "d", bench_steps=1000, cache=True).cached == 0
    # without cache=True nothing is read
    assert compare_costs(designs, private_cache / "e", bench_steps=1000).cached == 0


def test_a_tampered_entry_is_measured_again(private_cache):
    designs = {"LS(9)": presets.least_squares_design(9)}
    compare_costs(designs, private_cache / "a", bench_steps=1000, cache=True)
    entries = [p for p in cache_directory().glob("cost-*.json")
               if not p.name.endswith(".json.json")]  # the entry, not its sidecar
    assert len(entries) == 1
    text = entries[0].read_text(encoding="utf-8")
    entries[0].write_text(text.replace('"flops": ', '"flops": 1'), encoding="utf-8")
    table = compare_costs(designs, private_cache / "b", bench_steps=1000, cache=True)
    assert table.cached == 0 and table.rows[0].flops > 0


def test_key_follows_the_generated_files(private_cache):
    pkg = generate_c(presets.paper_design(), private_cache / "p")
    cc = find_compiler()
    key = cost_key(pkg, name="EHGO", bench_steps=10, compiler=cc)
    assert key == cost_key(pkg, name="EHGO", bench_steps=10, compiler=cc)
    (pkg.out_dir / "main.c").write_text((pkg.out_dir / "main.c").read_text() + "\n/* x */\n")
    assert key != cost_key(pkg, name="EHGO", bench_steps=10, compiler=cc)
