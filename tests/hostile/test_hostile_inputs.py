"""The hostile-input corpus: every file in files/ (and every bad option in cases.yaml) is refused.

Each case runs the real ``cyborg`` command in its own process, so a missing limit shows as
what a user would meet: a traceback, a hang (the timeout is only a guard against one) or a
process that grows without bound (the address-space limit stops it). What must come out is one
line naming what is wrong and the fix, and the exit code the case names.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from subprocess import CompletedProcess
from typing import Any

import pytest
import yaml

HERE = Path(__file__).parent
FILES = HERE / "files"
PLUGINS = HERE / "plugins"  # packages "installed" by putting their folder on PYTHONPATH
CASES: dict[str, dict[str, Any]] = yaml.safe_load((HERE / "cases.yaml").read_text(encoding="utf-8"))


def test_every_hostile_file_has_a_case() -> None:
    files = {path.name for path in FILES.iterdir() if not path.name.startswith("_")}
    assert files - set(CASES) == set(), "add the new file's expected refusal to cases.yaml"
    named_files = {name for name in CASES if "{file}" in CASES[name]["run"]}
    assert named_files <= files, "cases.yaml names files that are not in files/"


@pytest.mark.parametrize("name", sorted(CASES))
def test_hostile_input_is_refused_in_one_line_naming_the_fix(
    name: str, tmp_path: Path, cyborg: Callable[..., CompletedProcess[str]]
) -> None:
    case = CASES[name]
    places = {"{file}": str(FILES / name), "{ok}": str(FILES / "_ok_script.yaml"), "{tmp}": str(tmp_path)}
    args = [_fill(arg, places) for arg in case["run"]]
    plugins = PLUGINS / case["plugins"] if "plugins" in case else None
    result = cyborg(args, plugins=plugins, log_level=case.get("log_level", "ERROR"))
    output = result.stdout + result.stderr
    assert "Traceback" not in output, output
    assert result.returncode == case["exit"], output
    lines = [line for line in output.splitlines() if case["says"] in line]
    assert lines, f"no line says {case['says']!r}:\n{output}"
    assert "fix" in lines[0], f"the line names no fix: {lines[0]}"


def _fill(arg: str, places: dict[str, str]) -> str:
    for key, value in places.items():
        arg = arg.replace(key, value)
    return arg
