"""Each package's docstring names every module in it, so the folder list and its text agree.

A module added, renamed or moved without its package's docstring saying so fails here: that is
how package docstrings drifted from the code before.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "cyborg"
PACKAGES = sorted(p.parent for p in SRC.rglob("__init__.py") if p.parent != SRC)


def unnamed_modules(package: Path) -> list[str]:
    """The modules of ``package`` its docstring does not name (as a word: ``records`` or ``.records``)."""
    docstring = ast.get_docstring(ast.parse((package / "__init__.py").read_text(encoding="utf-8"))) or ""
    modules = [p.stem for p in package.glob("*.py") if p.stem not in ("__init__", "__main__")]
    modules += [p.name for p in package.iterdir() if (p / "__init__.py").is_file()]
    return sorted(m for m in modules if not re.search(rf"(?<![\w]){re.escape(m)}(?![\w])", docstring))


@pytest.mark.parametrize("package", PACKAGES, ids=lambda p: str(p.relative_to(SRC)))
def test_the_package_docstring_names_each_of_its_modules(package: Path) -> None:
    missing = unnamed_modules(package)
    assert missing == [], (
        f"cyborg/{package.relative_to(SRC)}/__init__.py does not name {', '.join(missing)}; fix: say in "
        "its docstring what each module holds"
    )


def test_a_module_the_docstring_does_not_name_is_found(tmp_path: Path) -> None:
    (tmp_path / "__init__.py").write_text('"""Holds `alpha` and :mod:`.beta`."""\n', encoding="utf-8")
    for name in ("alpha", "beta", "gamma", "alphabet"):
        (tmp_path / f"{name}.py").write_text("", encoding="utf-8")
    assert unnamed_modules(tmp_path) == ["alphabet", "gamma"]
