"""One exception tree: everything the cyborg package raises is a CyborgError (issue 13).

An exception class outside the tree must say why in its docstring (with the words
"not a CyborgError"); a plain ``raise ValueError(`` / ``RuntimeError(`` / ``TypeError(`` in
the source must be on the short allow-list below, with its reason.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest

import cyborg
import cyborg.errors as errors_module
from cyborg.errors import CyborgError

SRC = Path(cyborg.__file__).resolve().parent

OUTSIDE_MARK = "not a CyborgError"
"""What the docstring of an exception class outside the tree says, followed by why."""

PENDING_CLASSES: dict[str, str] = {}
"""Classes outside the tree for a while (qualified name: why); empty now."""

ALLOWED_RAISES: dict[str, str] = {}
"""Paths relative to src/cyborg (a folder ends in /) whose plain built-in raises may stay, and why; empty now."""

_PLAIN_RAISE = re.compile(r"\braise (ValueError|RuntimeError|TypeError)\(")


def _modules() -> list[str]:
    names = ["cyborg"]
    for info in pkgutil.walk_packages(cyborg.__path__, "cyborg."):
        names.append(info.name)
    return sorted(names)


def _import(name: str) -> object | None:
    """The module, or None for the ROS 2 transport (rclpy lives in .venv-ros2, not here)."""
    try:
        return importlib.import_module(name)
    except ImportError as exc:
        if name.startswith("cyborg.transport.ros2") and "rclpy" in str(exc):
            return None
        raise


def _exception_classes_in_source(name: str) -> list[str]:
    """Exception classes a module defines, read from its source: ``Name(bases)`` without a
    CyborgError base or a reason in the docstring."""
    path = SRC.parent / (name.replace(".", "/") + ".py")
    if not path.exists():
        path = SRC.parent / name.replace(".", "/") / "__init__.py"
    tree = ast.parse(path.read_text(encoding="utf-8"))
    tree_names = {
        n for n, v in vars(errors_module).items() if inspect.isclass(v) and issubclass(v, CyborgError)
    }
    outside = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ClassDef):
            continue
        bases = {
            b.id if isinstance(b, ast.Name) else b.attr if isinstance(b, ast.Attribute) else ""
            for b in node.bases
        }
        if not any(base.endswith(("Error", "Exception")) for base in bases):
            continue
        if bases & tree_names or OUTSIDE_MARK in (ast.get_docstring(node) or ""):
            continue
        outside.append(f"{name}.{node.name}")
    return outside


@pytest.mark.parametrize("name", _modules())
def test_every_exception_class_is_in_the_tree_or_says_why_not(name: str) -> None:
    module = _import(name)
    if module is None:  # read from its source instead
        outside = _exception_classes_in_source(name)
        assert outside == [], f"exception classes outside cyborg.errors.CyborgError: {outside}"
        return
    outside = []
    for attribute, value in vars(module).items():
        if not (inspect.isclass(value) and issubclass(value, BaseException)):
            continue
        if value.__module__ != name:  # imported, checked where it is defined
            continue
        qualified = f"{name}.{attribute}"
        if issubclass(value, CyborgError) or qualified in PENDING_CLASSES:
            continue
        if OUTSIDE_MARK not in (value.__doc__ or ""):
            outside.append(qualified)
    assert outside == [], (
        f"exception classes outside cyborg.errors.CyborgError: {outside}; fix: derive them from CyborgError "
        f"(or a subclass; keep a framework base as a second base), or say why in the docstring "
        f"with the words {OUTSIDE_MARK!r}"
    )


def test_no_plain_builtin_errors_are_raised() -> None:
    found = []
    for path in sorted(SRC.rglob("*.py")):
        relative = path.relative_to(SRC).as_posix()
        if any(relative.startswith(allowed) for allowed in ALLOWED_RAISES):
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            if _PLAIN_RAISE.search(line):
                found.append(f"{relative}:{number}: {line.strip()}")
    assert found == [], (
        "plain built-in errors raised (fix: raise cyborg.errors.InvalidValueError, which is also a "
        "ValueError, or another CyborgError):\n" + "\n".join(found)
    )


def test_the_allow_lists_are_short() -> None:
    assert len(ALLOWED_RAISES) <= 5 and len(PENDING_CLASSES) <= 3


def test_framework_errors_keep_their_framework_base() -> None:
    import click
    from aiohttp import web

    from cyborg.cli.db import InputError
    from cyborg.cli.tool import ToolError
    from cyborg.storage import Unusable
    from cyborg.web.api import CommandError

    assert issubclass(InputError, click.ClickException) and InputError("x").exit_code == 2
    assert issubclass(ToolError, click.ClickException)
    error = CommandError("bad")
    assert isinstance(error, web.HTTPBadRequest) and isinstance(error, CyborgError)
    assert error.status == 400 and error.text == '{"error": "bad"}'
    assert str(InputError("no such place")) == "no such place"
    from cyborg.errors import DatabaseError

    assert issubclass(Unusable, DatabaseError)
