"""Documentation is part of the feature: runnable examples, every parameter documented.

* every module's doctests run (shared set-up: ``fl`` and ``np`` are in every example's
  namespace; designs come from :mod:`fl_design.presets` rather than being re-typed);
* every public callable of the package and of its layers has a numpydoc docstring, parsed with
  ``numpydoc.docscrape``: each parameter of its signature is documented (whatever its name:
  ``*args``/``**kwargs`` included), no documented parameter is missing from the signature, and
  it has an Examples section that is not vacuous (not only ``callable(f)`` or ``f.__name__``)
  and, for a function, calls it.
"""

from __future__ import annotations

import doctest
import enum
import importlib
import inspect
import pkgutil
import re

import numpy as np
import pytest

import fl_design
import fl_design as fl

numpydoc_docscrape = pytest.importorskip("numpydoc.docscrape")

MODULES = sorted(
    m.name for m in pkgutil.walk_packages(fl_design.__path__, "fl_design.")
    if m.name not in {"fl_design.__main__"}
)
LAYERS = ("symbolic", "design", "sim", "analysis", "codegen", "app")


@pytest.mark.parametrize("name", MODULES)
def test_doctest_examples_run(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # examples that write files write them here
    module = importlib.import_module(name)
    result = doctest.testmod(module, extraglobs={"fl": fl, "np": np},
                             optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} doctest example(s) failed in {name}"


def _public_objects():
    seen = set()
    spaces = [("fl", fl, fl.__all__)]
    spaces += [(f"fl.{layer}", getattr(fl, layer), getattr(fl, layer).__all__) for layer in LAYERS]
    spaces += [("fl.plants", fl.plants, fl.plants.__all__)]
    spaces += [("fl.presets", fl.presets, fl.presets.__all__)]
    for prefix, space, names in spaces:
        for name in names:
            obj = getattr(space, name)
            if not (inspect.isclass(obj) or inspect.isfunction(obj)) or id(obj) in seen:
                continue
            seen.add(id(obj))
            yield f"{prefix}.{name}", obj


PUBLIC = list(_public_objects())


def _signature_params(obj) -> list[str]:
    target = obj
    if inspect.isclass(obj) and issubclass(obj, enum.Enum):
        return []
    if inspect.isclass(obj):
        if obj.__init__ is object.__init__:
            return []
        target = obj.__init__
    try:
        params = inspect.signature(target).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins
        return []
    out = []
    for p in params.values():
        if p.name in ("self", "cls") or p.name.startswith("_"):
            continue
        out.append(("*" if p.kind is p.VAR_POSITIONAL else "**" if p.kind is p.VAR_KEYWORD
                    else "") + p.name)
    return out


def _documented(doc) -> set[str]:
    names = set()
    for section in ("Parameters", "Other Parameters"):
        for entry in doc[section]:
            for part in entry.name.split(","):
                names.add(part.strip())
    return names


@pytest.mark.parametrize("name,obj", PUBLIC, ids=[n for n, _ in PUBLIC])
def test_every_parameter_is_documented(name, obj):
    text = inspect.getdoc(obj) or ""
    assert text, f"{name} has no docstring"
    doc = numpydoc_docscrape.ClassDoc(obj) if inspect.isclass(obj) else \
        numpydoc_docscrape.FunctionDoc(obj)
    params = _signature_params(obj)
    documented = _documented(doc)
    missing = [p for p in params if p not in documented and p.lstrip("*") not in documented]
    assert not missing, f"{name} does not document parameter(s) {missing}"
    plain = {p.lstrip("*") for p in params}
    extra = [d for d in documented if d.lstrip("*") not in plain]
    if params or not inspect.isclass(obj):
        assert not extra, f"{name} documents parameter(s) {extra} that its signature lacks"


_VACUOUS = re.compile(r"^(callable\(\w+(\.\w+)*\)|\w+(\.\w+)*\.__name__|\w+\.__doc__)$")


@pytest.mark.parametrize("name,obj", PUBLIC, ids=[n for n, _ in PUBLIC])
def test_examples_exercise_the_object(name, obj):
    doc = numpydoc_docscrape.ClassDoc(obj) if inspect.isclass(obj) else \
        numpydoc_docscrape.FunctionDoc(obj)
    examples = "\n".join(doc["Examples"])
    assert ">>>" in examples, f"{name} has no runnable Examples section"
    sources = [e.source.strip() for e in doctest.DocTestParser().get_examples(examples)]
    code = [s for s in sources if not s.startswith(("import ", "from "))]
    assert code and not all(_VACUOUS.match(s) for s in code), \
        f"{name}: its examples only check that something exists ({code})"
    if not inspect.isclass(obj):  # a function's example calls it
        short = obj.__name__
        assert any(re.search(rf"\b{re.escape(short)}\(", s) for s in code), \
            f"{name}: no example calls {short}(...)"
