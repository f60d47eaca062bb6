"""Imports flow one way through the layers of docs/architecture.md, and no module imports itself back.

Every import statement of ``src/cyborg`` counts, also those inside functions (lazy imports)
and under ``TYPE_CHECKING``: a lazy import that runs against the layers is a hidden cycle.
"""

from __future__ import annotations

import ast
import functools
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support.paths import DOCS, ROOT

SRC = ROOT / "src" / "cyborg"
DOC = DOCS / "architecture.md"

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


@functools.cache
def sources() -> tuple[Path, ...]:
    """Every module of the package, in path order."""
    return tuple(sorted(SRC.rglob("*.py")))


@functools.cache
def tree_of(path: Path) -> ast.Module:
    """``path`` parsed, once for all the tests here."""
    return ast.parse(path.read_text(encoding="utf-8"))


def imports_of(path: Path) -> Iterator[tuple[int, str]]:
    """(line, imported cyborg module) for every import in ``path``, however deep in the code."""
    module = module_name(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(tree_of(path)):
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


@functools.cache
def all_imports() -> dict[str, list[tuple[int, str]]]:
    found: dict[str, list[tuple[int, str]]] = {}
    for path in sources():
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


def third_party_imports(path: Path) -> Iterator[tuple[int, str]]:
    """(line, module) of every absolute import of ``path`` outside this package."""
    for node in ast.walk(tree_of(path)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            yield node.lineno, node.module


OWNERS = {
    "aiohttp": {"web", "client"},  # the server in web/, a websocket client in client/
    "rospy": {"transport"},
    "rclpy": {"transport"},
    "actionlib": {"transport"},
    "rospkg": {"transport", "run"},  # ROS 1's log folder, for the middleware's log_file
    "click": {"cli", "run"},  # run/ prints a node's state as the command line does
}
"""Which packages may import a framework: each one's code sits behind one boundary."""


def test_frameworks_are_imported_only_behind_their_boundary() -> None:
    wrong = []
    for path in sources():
        own = package_of(module_name(path))
        for line, name in third_party_imports(path):
            owners = OWNERS.get(name.split(".")[0])
            if owners is not None and own not in owners:
                wrong.append(f"{module_name(path)}:{line} imports {name} (only {sorted(owners)} may)")
    assert wrong == [], "\n".join(wrong)


def test_aiohttp_serves_only_from_web() -> None:
    wrong = [
        f"{module_name(path)}:{line}"
        for path in sources()
        for line, name in third_party_imports(path)
        if name.startswith("aiohttp")
        and package_of(module_name(path)) != "web"
        and _imports_server(path, line)
    ]
    assert wrong == [], "aiohttp's server outside cyborg.web: " + ", ".join(wrong)


def _imports_server(path: Path, line: int) -> bool:
    text = path.read_text(encoding="utf-8").splitlines()[line - 1]
    return "web" in text.split("import", 1)[-1] or "aiohttp.web" in text


MIDDLEWARE_AWARE = {"run", "transport"}
"""Only these packages may ask which ROS the robot runs on."""


def test_no_middleware_switch_outside_run_and_the_transports() -> None:
    """The middleware is a strategy object (``cyborg.run.middleware``): no ``ros2`` flag is passed
    through other layers, and nothing else asks ``ros_version``."""
    wrong = []
    for path in sources():
        if package_of(module_name(path)) in MIDDLEWARE_AWARE:
            continue
        for node in ast.walk(tree_of(path)):
            if isinstance(node, ast.arg) and node.arg in ("ros2", "ros_version"):
                wrong.append(f"{module_name(path)}:{node.lineno} parameter {node.arg}")
            elif isinstance(node, ast.Attribute) and node.attr in ("ros2", "ros_version"):
                wrong.append(f"{module_name(path)}:{node.lineno} .{node.attr}")
            elif isinstance(node, ast.keyword) and node.arg in ("ros2", "ros_version"):
                wrong.append(f"{module_name(path)}:{node.lineno} {node.arg}=")
    assert wrong == [], "\n".join(wrong)


def test_the_boundary_checks_see_a_violation() -> None:
    """The AST walks find what they look for (a check that could not fail proves nothing)."""
    tree = ast.parse("def f(ros2: bool) -> None:\n    node.ros_version\n    g(ros2=True)\n")
    found = [n for n in ast.walk(tree) if isinstance(n, ast.arg | ast.Attribute | ast.keyword)]
    names = {getattr(n, "arg", None) or getattr(n, "attr", None) for n in found}
    assert {"ros2", "ros_version"} <= names
