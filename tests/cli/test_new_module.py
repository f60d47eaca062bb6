"""cyborg new module NAME: a package that installs, passes its own test and runs in a scenario."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from cyborg.cli import cli
from cyborg.cli.new import module_files
from cyborg.errors import InvalidValueError
from tests.support.tools import CYBORG_SCRIPT, pythonpath


@pytest.fixture(scope="module")
def greeter(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The package written by `cyborg new module greeter`, pip-installed into a folder of its own."""
    parent = tmp_path_factory.mktemp("student")
    result = CliRunner().invoke(cli, ["new", "module", "greeter", "--dir", str(parent)])
    assert result.exit_code == 0, result.output
    assert "pip install -e ." in result.output
    site = tmp_path_factory.mktemp("site")
    copy = tmp_path_factory.mktemp("build") / "greeter"  # pip builds in the folder: keep the student's clean
    shutil.copytree(parent / "greeter", copy)
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "--target",
            str(site),
            str(copy),
        ],
        check=True,
        capture_output=True,
    )
    return parent / "greeter", site


def run(site: Path, *args: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, **pythonpath(site)}
    return subprocess.run([*map(str, args)], env=env, cwd=cwd, capture_output=True, text=True, timeout=300)


def test_the_package_holds_what_a_student_needs(greeter: tuple[Path, Path]) -> None:
    folder, _ = greeter
    files = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())
    assert files == [
        "README.md",
        "pyproject.toml",
        "robot.yaml",
        "scenario.yaml",
        "src/greeter/__init__.py",
        "src/greeter/module.py",
        "src/greeter/rclpy_node.py",
        "src/greeter/rospy_node.py",
        "tests/test_module.py",
    ]
    assert 'greeter = "greeter.module:KIND"' in (folder / "pyproject.toml").read_text()
    for source in folder.rglob("*.py"):
        compile(source.read_text(), str(source), "exec")  # every template filled in


def test_its_own_test_passes_and_every_command_knows_the_kind(greeter: tuple[Path, Path]) -> None:
    folder, site = greeter
    tests = run(site, sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests", cwd=folder)
    assert tests.returncode == 0, tests.stdout + tests.stderr
    assert "3 passed" in tests.stdout
    assert "Warning" not in tests.stdout + tests.stderr, tests.stdout + tests.stderr  # e.g. pytest-asyncio's
    kinds = run(site, CYBORG_SCRIPT, "kinds", cwd=folder)
    assert "greeter" in kinds.stdout and "cyborg-greeter 0.1.0" in kinds.stdout
    valid = run(site, CYBORG_SCRIPT, "validate", "robot.yaml", cwd=folder)
    assert valid.returncode == 0 and "warning" not in valid.stderr, valid.stderr


def test_its_scenario_with_expect_steps_passes_in_cyborg_sim(greeter: tuple[Path, Path]) -> None:
    folder, site = greeter
    result = run(
        site,
        CYBORG_SCRIPT,
        "sim",
        "--config",
        "robot.yaml",
        "--script",
        "scenario.yaml",
        "--speed",
        "max",
        cwd=folder,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert "idle --greeter_wanted--> greeter" in result.stdout
    assert "Cyborg: Hello! I am the greeter module." in result.stdout


def test_a_name_that_cannot_be_a_module_is_refused_and_nothing_is_written(tmp_path: Path) -> None:
    for bad in ("Greeter", "2fast", "class", "cyborg_x", "my-module"):
        with pytest.raises(InvalidValueError, match="fix: use lower-case letters"):
            module_files(bad)
    result = CliRunner().invoke(cli, ["new", "module", "my-module", "--dir", str(tmp_path)])
    assert result.exit_code == 1 and list(tmp_path.iterdir()) == []
    (tmp_path / "taken").mkdir()
    result = CliRunner().invoke(cli, ["new", "module", "taken", "--dir", str(tmp_path)])
    assert result.exit_code == 1 and "exists already" in result.output
