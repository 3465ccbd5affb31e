"""The house's rules, checked on the source: data flows one way, layers export their API only.

* no import cycle between fl_design's subpackages and top-level modules (imports inside
  functions count: a lazy import is still a dependency);
* no library layer imports ``app``; ``analysis`` and ``codegen`` never import each other;
* each layer's ``__all__`` is its public API (at most :data:`MAX_EXPORTS` names), and every
  name in it is documented (the docstring test covers them).
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "fl_design"
LAYERS = ("symbolic", "design", "sim", "analysis", "codegen", "app")
MAX_EXPORTS = 20


def _unit(path: Path) -> str:
    rel = path.relative_to(ROOT).parts
    return rel[0] if len(rel) > 1 else rel[0].removesuffix(".py")


def _edges() -> set[tuple[str, str]]:
    edges = set()
    for path in ROOT.rglob("*.py"):
        src = _unit(path)
        pkg = ".".join(("fl_design", *path.relative_to(ROOT).parts[:-1]))
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                    mod = ".".join(base + ([node.module] if node.module else []))
                else:
                    mod = node.module or ""
                names = [mod] if node.module else [f"{mod}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            for name in names:
                parts = name.split(".")
                if parts[0] == "fl_design" and len(parts) > 1 and parts[1] not in (src,
                                                                                    "__init__"):
                    edges.add((src, parts[1]))
    return edges


EDGES = _edges()


def _reaches(a: str, b: str) -> bool:
    graph: dict[str, set[str]] = {}
    for x, y in EDGES:
        graph.setdefault(x, set()).add(y)
    seen, stack = set(), [a]
    while stack:
        n = stack.pop()
        if n == b:
            return True
        if n not in seen:
            seen.add(n)
            stack.extend(graph.get(n, ()))
    return False


def test_the_import_graph_is_seen():
    assert ("sim", "design") in EDGES and ("app", "sim") in EDGES  # the checker works


def test_no_import_cycle_between_subpackages_and_modules():
    cycles = sorted({tuple(sorted((a, b))) for a, b in EDGES
                     if "__main__" not in (a, b) and _reaches(b, a)})
    assert not cycles, f"import cycles: {cycles}"


def test_no_library_layer_imports_app():
    bad = sorted(a for a, b in EDGES if b == "app" and a not in ("__main__", "__init__"))
    assert not bad


def test_analysis_and_codegen_never_import_each_other():
    assert ("analysis", "codegen") not in EDGES and ("codegen", "analysis") not in EDGES


@pytest.mark.parametrize("layer", LAYERS)
def test_a_layer_exports_its_api_only(layer):
    module = importlib.import_module(f"fl_design.{layer}")
    assert len(module.__all__) <= MAX_EXPORTS, sorted(module.__all__)
    for name in module.__all__:
        assert getattr(module, name).__doc__ or name.isupper(), f"{layer}.{name} undocumented"


def test_the_readme_box_lists_every_module():
    """README's "What is in the box" names each layer's modules exactly as the tree holds them."""
    import re

    text = (ROOT.parent / "README.md").read_text()
    box = text[text.index("## What is in the box"):]
    for layer in ("symbolic", "design", "sim", "analysis", "codegen", "app", "plants"):
        row = next(line for line in box.splitlines() if line.startswith(f"| `{layer}/` |"))
        listed = set(re.findall(r"`(_\w+)`", row.split("|")[2]))
        folder = ROOT / layer
        have = {p.stem for p in folder.glob("_*.py") if p.stem != "__init__"}
        if layer == "sim":
            have |= {p.stem for p in (folder / "kernel").glob("_*.py") if p.stem != "__init__"}
        assert listed == have, f"{layer}: README lists {sorted(listed - have)} not in the " \
                               f"tree, misses {sorted(have - listed)}"
