"""What a source file of fl_design imports, read from its syntax tree (nothing is imported).

Shared by the architecture tests (``tests/test_architecture.py``, ``tests/ui/test_layering.py``):
one reading of ``import`` and ``from ... import`` statements, relative ones resolved.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "fl_design"


def module_name(path: Path) -> str:
    """``fl_design.sim._run`` for ``ROOT / "sim" / "_run.py"`` (a package: its ``__init__``)."""
    rel = ".".join(("fl_design", *path.relative_to(ROOT).with_suffix("").parts))
    return rel.removesuffix(".__init__")


def imported_names(path: Path, *, type_checking: bool = True) -> set[str]:
    """Every dotted name an import anywhere in ``path`` names (functions' bodies included).

    ``from m import a`` names both ``m`` and ``m.a`` (``a`` may be a module or an attribute);
    relative imports are resolved against the file's package. ``type_checking=False`` skips
    the imports under ``if TYPE_CHECKING:``.
    """
    name = module_name(path)
    pkg = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text())
    skip = set()
    if not type_checking:
        for node in ast.walk(tree):
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                skip |= {id(m) for m in ast.walk(node)}
    out = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out |= {mod, *(f"{mod}.{a.name}" for a in node.names)}
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
    return out
