"""Documentation is part of the feature: runnable examples and every parameter documented."""

from __future__ import annotations

import doctest
import importlib
import inspect
import pkgutil

import pytest

import fl_design

MODULES = sorted(
    m.name for m in pkgutil.walk_packages(fl_design.__path__, "fl_design.")
    if m.name not in {"fl_design.__main__"}
)


@pytest.mark.parametrize("name", MODULES)
def test_doctest_examples_run(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # examples that write files write them here
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} doctest example(s) failed in {name}"


def _public_callables():
    for name in fl_design.__all__:
        if name in {"errors", "__version__", "plants"}:
            continue
        obj = getattr(fl_design, name)
        if callable(obj):
            yield name, obj
    plants = importlib.import_module("fl_design.plants")
    for name, obj in vars(plants).items():
        if inspect.isfunction(obj) and obj.__module__ == plants.__name__ and not name.startswith("_"):
            yield f"plants.{name}", obj


@pytest.mark.parametrize("name,obj", list(_public_callables()), ids=lambda v: v if isinstance(v, str) else "")
def test_public_api_documents_every_parameter(name, obj):
    doc = inspect.getdoc(obj) or ""
    assert "Examples" in doc, f"{name} has no Examples section"
    target = obj.__init__ if inspect.isclass(obj) else obj
    if inspect.isclass(obj) and (obj.__init__ is object.__init__):
        return
    try:
        params = inspect.signature(target).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins
        return
    missing = [p for p in params if p not in {"self", "args", "kwargs"} and p not in doc]
    assert not missing, f"{name} does not document parameter(s) {missing}"
