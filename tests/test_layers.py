"""Imports flow one way through the layers of docs/architecture.md, and no module imports itself back.

Every import statement of ``src/cyborg`` counts, also those inside functions (lazy imports)
and under ``TYPE_CHECKING``: a lazy import that runs against the layers is a hidden cycle.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "cyborg"
DOC = ROOT / "docs" / "architecture.md"

LAYERS: list[set[str]] = [
    {"errors", "limits"},
    {"transport"},
    {"configfile", "storage", "maps"},
    {"controller"},
    {"drawing"},
    {"emotion"},
    {"motivator"},
    {"modules"},
    {"navigation", "hearing"},
    {"app"},
    {"observe"},
    {"sim", "testing"},
    {"web"},
    {"run"},
    {"client"},
    {"cli"},
]
"""Lowest first. A package may import its own layer's packages and those below; never above."""

LEVEL = {package: level for level, packages in enumerate(LAYERS) for package in packages}


def module_name(path: Path) -> str:
    parts = path.relative_to(SRC.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def package_of(module: str) -> str:
    """``cyborg.navigation.module`` -> ``navigation``; ``cyborg.errors`` -> ``errors``.

    ``cyborg`` itself and ``cyborg.__version__`` (a string, importing nothing) are in no layer: "".
    """
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] != "__version__" else ""


def imports_of(path: Path) -> Iterator[tuple[int, str]]:
    """(line, imported cyborg module) for every import in ``path``, however deep in the code."""
    module = module_name(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            for alias in node.names:
                candidate = f"{base}.{alias.name}"
                yield node.lineno, candidate if _is_module(candidate) else base


def _is_module(name: str) -> bool:
    relative = Path(*name.split(".")[1:])
    return (SRC / relative).with_suffix(".py").is_file() or (SRC / relative / "__init__.py").is_file()


def all_imports() -> dict[str, list[tuple[int, str]]]:
    found: dict[str, list[tuple[int, str]]] = {}
    for path in sorted(SRC.rglob("*.py")):
        found[module_name(path)] = [
            (line, target) for line, target in imports_of(path) if target.split(".")[0] == "cyborg"
        ]
    return found


def test_every_package_has_a_layer() -> None:
    packages = {package_of(m) for m in all_imports()} - {""}
    assert packages - set(LEVEL) == set(), "add the new package to LAYERS and to docs/architecture.md"


def test_imports_never_run_up_the_layers() -> None:
    wrong = []
    for module, targets in all_imports().items():
        own = package_of(module)
        for line, target in targets:
            other = package_of(target)
            if own and other and LEVEL[other] > LEVEL[own]:
                wrong.append(f"{module}:{line} imports {target} ({own} sits below {other})")
    assert wrong == [], "imports against the layers:\n" + "\n".join(wrong)


def test_no_import_cycles_between_modules() -> None:
    graph = {m: {t for _, t in ts if t != m} for m, ts in all_imports().items()}
    cycles = [c for c in strongly_connected(graph) if len(c) > 1]
    assert cycles == [], "modules that import each other (lazily or not): " + "; ".join(
        " <-> ".join(sorted(c)) for c in cycles
    )


def strongly_connected(graph: dict[str, set[str]]) -> list[set[str]]:
    """Tarjan's algorithm, iteratively."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[set[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in graph:
                    continue
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                found.append(component)
    return found


def test_the_checks_catch_what_they_are_for() -> None:
    """The walker sees a lazy import inside a function, and the cycle finder finds a cycle."""
    assert LEVEL["sim"] > LEVEL["motivator"]
    source = "def f():\n    from cyborg.sim.base import SimulatedBase\n"
    tree = ast.parse(source)
    lazy = [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    assert lazy and lazy[0].module == "cyborg.sim.base"
    assert strongly_connected({"a": {"b"}, "b": {"a"}, "c": {"a"}}) == [{"a", "b"}, {"c"}]


def test_the_doc_lists_the_same_layers() -> None:
    """docs/architecture.md's numbered list of layers is this test's LAYERS, lowest first."""
    text = DOC.read_text(encoding="utf-8")
    section = text.split("## Layers", 1)[1].split("\n## ", 1)[0]
    listed = [
        set(re.findall(r"`cyborg\.(\w+)`", line)) for line in re.findall(r"^\d+\. (.*)$", section, re.M)
    ]
    assert listed == LAYERS


@pytest.mark.parametrize(
    ("importer", "imported"),
    [
        ("cyborg.motivator.component", "cyborg.app.robot"),
        ("cyborg.navigation.database", "cyborg.sim.maps"),
        ("cyborg.maps", "cyborg.app.config"),
        ("cyborg.controller.config", "cyborg.motivator.logic"),
        ("cyborg.emotion.system", "cyborg.motivator.store"),
    ],
)
def test_the_imports_the_review_found_would_fail(importer: str, imported: str) -> None:
    """The imports issue 13's review listed (in their new homes) run against the layers."""
    assert LEVEL[package_of(imported)] > LEVEL[package_of(importer)]
