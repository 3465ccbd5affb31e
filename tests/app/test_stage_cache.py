"""The main job's certify and derive stages cached by content: same results, keyed on what
they depend on, never loaded from a file another user could have written."""

from __future__ import annotations

import dataclasses
import warnings

import pytest

from fl_design._cache import cache_directory
from fl_design.app import load_config, parse_config, run_job
from fl_design.app._job import prepare
from fl_design.app._report_write import summary
from fl_design.app._stage_cache import cached_stage, stage_key
from fl_design.errors import CacheWarning


@pytest.fixture()
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _counting():
    calls = []

    def compute():
        calls.append(1)
        return {"skipped": f"computed {len(calls)}"}

    return calls, compute


def test_second_call_reads_the_cache_and_a_changed_table_misses(private_cache):
    job = prepare(load_config(None))
    calls, compute = _counting()
    first, hit1 = cached_stage(job, "certify", True, compute)
    second, hit2 = cached_stage(job, "certify", True, compute)
    assert (hit1, hit2, len(calls)) == (False, True, 1) and first == second
    assert any(private_cache.glob("certify_*_results.pkl"))
    # what the results depend on changes the key: quick mode, the [certify] table, the design
    assert cached_stage(job, "certify", False, compute) == ({"skipped": "computed 2"}, False)
    other = prepare(parse_config("[certify]\npoints = 5\n"))
    assert stage_key(other, "certify", True) != stage_key(job, "certify", True)
    gamma = prepare(parse_config("[design]\ngamma = 2e-4\n"))
    assert stage_key(gamma, "certify", True) not in (stage_key(job, "certify", True), stage_key(other, "certify", True))
    # the presentation's sources are not part of the key; a second job of the same config is
    assert stage_key(prepare(load_config(None)), "certify", True) == stage_key(job, "certify", True)


def test_a_file_not_signed_with_the_users_key_is_recomputed(private_cache):
    job = prepare(load_config(None))
    calls, compute = _counting()
    cached_stage(job, "certify", True, compute)
    (entry,) = [p for p in cache_directory().glob("certify_*_results.pkl")]
    # a planted pickle with a valid size/SHA-256 sidecar but no valid signature
    from fl_design._cache import write_verified

    write_verified(entry.name, b"\0" * 32 + b"cos\nsystem\n(S'echo planted'\ntR.",
                   cache_dir=entry.parent)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value, hit = cached_stage(job, "certify", True, compute)
    assert (hit, len(calls)) == (False, 2) and value == {"skipped": "computed 2"}
    assert any(issubclass(w.category, CacheWarning) for w in caught)
    assert cached_stage(job, "certify", True, compute) == ({"skipped": "computed 2"}, True)  # rewritten


def test_errors_are_not_cached(private_cache):
    job = prepare(load_config(None))

    def fail():
        raise RuntimeError("solver exploded")

    with pytest.raises(RuntimeError, match="solver exploded"):
        cached_stage(job, "certify", True, fail)
    assert not any(private_cache.glob("certify_*"))


def test_cached_job_equals_a_fresh_one(private_cache):
    """The real stage: a second job reads the cache and reports exactly the same numbers."""
    first = run_job(load_config(None), quick=True, stages=("certify",), progress=False)
    again = run_job(load_config(None), quick=True, stages=("certify",), progress=False)
    assert "certify" not in first.cached and "certify" in again.cached
    assert summary(first)["certify"] == summary(again)["certify"]
    margins = again.results["certify"]["margins"]
    assert [m["b"] for m in margins] == list(again.results["certify"]["eps"].b_bounds)
    assert all("keeps it stable" in m["text"] for m in margins)
    cert = again.results["certify"]
    # the cached certificate is the TRMS's class certificate (its bracket's refuted end found)
    assert dataclasses.is_dataclass(cert["eps"]) and cert["eps"].plant_class.source == "plant"
    assert cert["eps"].bracket(cert["eps"].covers).refuted > 0


def test_the_derive_stage_is_cached_by_plant_only(private_cache):
    """The derivation reads only [plant]: another design shares it, another plant does not;
    the cached dict equals the fresh one."""
    first = run_job(load_config(None), stages=("derive",), progress=False)
    again = run_job(parse_config("[design]\ngamma = 2e-4\n"), stages=("derive",),
                    progress=False)
    assert "derive" not in first.cached and "derive" in again.cached
    assert again.derivation == first.derivation and again.derivation["rho"] == 2
    other = prepare(parse_config('[plant]\nlibrary = "pendulum"\n'))
    assert stage_key(other, "derive", False) != stage_key(first, "derive", False)
    assert stage_key(first, "derive", False) != stage_key(first, "certify", False)
