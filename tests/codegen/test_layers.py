"""No import circle inside ``fl_design/codegen`` (generation -> package -> checks, one way).

Every import counts, at module level or inside a function; only a ``TYPE_CHECKING`` block
does not (annotations, never run).
"""

from __future__ import annotations

import ast
from pathlib import Path

import fl_design.codegen

ROOT = Path(fl_design.codegen.__file__).parent


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for n in ast.walk(node))
    out = set()
    for node in ast.walk(tree):
        if id(node) in skip or not isinstance(node, ast.ImportFrom) or node.level != 1:
            continue
        if node.module:
            out.add(node.module.split(".")[0])
        else:
            out.update(a.name for a in node.names)
    return out


def graph() -> dict[str, set[str]]:
    mods = {p.stem for p in ROOT.glob("_*.py") if p.stem != "__init__"}
    return {m: _imports(ROOT / f"{m}.py") & mods for m in mods}


def cycle(g: dict[str, set[str]]) -> list[str] | None:
    """One import circle of ``g`` (depth-first search), or None."""
    state, stack = {}, []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for n in sorted(g[m]):
            if state.get(n) == 1:
                return stack[stack.index(n):] + [n]
            if n not in state and (found := visit(n)):
                return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(g):
        if m not in state and (found := visit(m)):
            return found
    return None


def test_cycle_finder_finds_a_circle():
    assert cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_circle_in_codegen():
    g = graph()
    assert len(g) >= 10
    assert cycle(g) is None, " -> ".join(cycle(g))


def test_checks_never_import_generation_or_the_package():
    g = graph()
    for check in ("_sil", "_pil", "_cost", "_float_check", "_compare", "_verdict"):
        assert not g[check] & {"_generate", "_package"}, (check, g[check])
