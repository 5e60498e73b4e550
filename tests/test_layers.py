"""The package's shape (ARCHITECTURE.md): imports run one way, from the command line down to the data model,
and no modules import each other in a circle. Lazy imports inside functions count as imports here."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Installed name of each top-level source folder (factors/ and nets/ install inside graphnav).
PACKAGES = {"graphnav": "graphnav", "factors": "graphnav.factors", "nets": "graphnav.nets"}
#: Rank of each group: a module may import its own group and groups of lower rank only.
LAYERS = {
    "graphnav.core": 0,
    "graphnav.io": 1,
    "graphnav.factors": 2, "graphnav.sim": 2,
    "graphnav.estimators": 3,
    "graphnav.calibration": 4,
    "graphnav.missions": 5,
    "graphnav.nets": 6,
    "graphnav.evaluation": 7,
    "graphnav.commands": 8,
    "graphnav.cli": 9, "graphnav.__main__": 10,
}


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = [PACKAGES[rel.parts[0]], *rel.parts[1:]]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for top in PACKAGES for p in (ROOT / top).rglob("*.py")}


def imported(path: Path, name: str, known: set[str]) -> set[str]:
    """The graphnav modules ``path`` imports anywhere in its body (absolute and relative imports)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                base = ".".join(up + ([base] if base else []))
            # `from package import submodule` imports the submodule; `from module import name`, the module
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        else:
            continue
        found |= {t for t in targets if t in known}
    found.discard(name)
    return found


def group(module: str) -> str:
    return max((g for g in LAYERS if module == g or module.startswith(g + ".")), key=len, default="graphnav")


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    mods = modules()
    return {name: imported(path, name, set(mods)) for name, path in mods.items()}


def test_every_module_has_a_layer(graph):
    assert [m for m in graph if group(m) == "graphnav" and m != "graphnav"] == []


def test_imports_run_down_the_layers(graph):
    # the package's own __init__ (the public face, lazy exports) stands apart from the layers
    upward = [f"{m} -> {t}" for m, targets in graph.items() for t in targets
              if "graphnav" not in (group(m), group(t)) and group(t) != group(m)
              and LAYERS[group(t)] >= LAYERS[group(m)]]
    assert upward == []


def test_no_import_circles(graph):
    # Tarjan's strongly connected components over the module graph (a package's __init__ is a module too)
    index, low, stack, on_stack, circles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    assert circles == []
