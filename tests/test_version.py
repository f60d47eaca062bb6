"""The version is written once, in ``src/cyborg/__version__.py``, and the build reads it from there."""

from __future__ import annotations

import tomllib

from packaging.version import Version  # pytest depends on packaging

import cyborg
from tests.support.paths import ROOT


def test_pyproject_reads_the_version_from_the_package() -> None:
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert "version" not in pyproject["project"], "write the version in src/cyborg/__version__.py only"
    assert "version" in pyproject["project"]["dynamic"]
    assert pyproject["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "cyborg.__version__.__version__"}


def test_the_version_is_a_pep_440_string() -> None:
    assert str(Version(cyborg.__version__)) == cyborg.__version__
