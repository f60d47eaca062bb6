"""The README's Quick start: exactly two commands, and the first one works on a clean clone."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
from pathlib import Path

import pytest

from tests.support.paths import ROOT, SHARED


def quick_start_commands() -> list[str]:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    [block] = re.findall(r"```sh\n(.*?)```", section, re.S)
    return [line.split("#", 1)[0].strip() for line in block.splitlines() if line.split("#", 1)[0].strip()]


def test_quick_start_has_exactly_two_commands_and_ci_runs_the_second() -> None:
    run, test = quick_start_commands()
    assert run == "./scripts/run" and test == "./scripts/test"
    ci = (ROOT / ".ci" / "run").read_text()
    assert "scripts/test" in ci
    for command in (run, test):
        assert os.access(ROOT / command, os.X_OK)


@pytest.mark.e2e
@pytest.mark.timeout(900)  # the run below may take 600 s: a fresh .venv, every dependency, 400 s of robot
def test_main_job_runs_from_a_clean_clone(tmp_path: Path) -> None:
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    (tmp_path / "shared").symlink_to(SHARED)
    run, _ = quick_start_commands()
    result = subprocess.run(
        [
            *shlex.split(run),
            "--speed",
            "max",
            "--duration",
            "400",
            "--port",
            "0",
            "--db",
            str(tmp_path / "data"),
        ],
        cwd=clone,
        capture_output=True,
        text=True,
        timeout=600,
        env={k: v for k, v in os.environ.items() if k != "VIRTUAL_ENV"},
    )
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    assert (clone / ".venv" / "bin" / "cyborg").exists()
    assert "dashboard and API: http://127.0.0.1:" in result.stdout
    assert "- --start--> idle" in result.stdout
    assert "--navigation_emotional--> navigation_planning" in result.stdout  # the motivator got it going


def test_the_readme_names_every_helper_script_a_user_runs_and_each_exists() -> None:
    readme = (ROOT / "README.md").read_text()
    for script in ("scripts/run", "scripts/test", "scripts/screenshot"):
        assert script in readme, f"README.md does not mention {script}"
        assert os.access(ROOT / script, os.X_OK), f"{script} is named in README.md but is no executable file"
