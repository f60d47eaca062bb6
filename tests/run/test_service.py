"""``cyborg service``: the unit that starts the robot at boot, checked by systemd's own analyzer.

``systemd-analyze verify`` (scripts/install-system-deps --test installs it) loads the unit as
systemd would at boot: its syntax, that ExecStart's program exists and is executable, that the
user and the targets exist. Where systemd is not running, install, status and uninstall refuse
with the fix.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner

from cyborg.cli import cli
from cyborg.run import service


def _verify(unit: Path) -> subprocess.CompletedProcess[str]:
    analyzer = shutil.which("systemd-analyze")
    assert analyzer, "systemd-analyze is missing; fix: scripts/install-system-deps --test"
    return subprocess.run([analyzer, "verify", str(unit)], capture_output=True, text=True, timeout=60)


def test_the_unit_runs_cyborg_launch_with_the_shells_ros_settings_and_systemd_accepts_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ROS_MASTER_URI", "http://cyborg-nuc:11311")
    monkeypatch.setenv("ROS_IP", "10.0.0.7")
    monkeypatch.setenv("CYBORG_TOKEN", "a token with spaces and a % sign")
    unit = tmp_path / "cyborg.service"
    data = tmp_path / "robot data"
    args = ["service", "install", "--config", "robot", "--db", str(data), "--ros2", "--write", str(unit)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    text = unit.read_text()
    assert 'Environment="ROS_MASTER_URI=http://cyborg-nuc:11311"' in text
    assert 'Environment="ROS_IP=10.0.0.7"' in text
    assert 'Environment="CYBORG_TOKEN=a token with spaces and a %% sign"' in text
    assert "Restart=on-failure" in text and "StandardOutput=journal" in text and "KillSignal=SIGINT" in text
    [exec_start] = [line for line in text.splitlines() if line.startswith("ExecStart=")]
    assert " launch --config " in exec_start and exec_start.endswith("--ros2")
    assert str(Path(service.__file__).parents[1] / "data" / "robot.yaml") in exec_start
    assert f'"{data.resolve()}"' in exec_start  # quoted: the folder has a space
    checked = _verify(unit)
    assert checked.returncode == 0, checked.stderr

    # The analyzer is no rubber stamp: a unit whose program is gone fails it.
    unit.write_text(text.replace(exec_start, "ExecStart=/nonexistent/python -m cyborg.cli launch"))
    assert _verify(unit).returncode != 0


@pytest.mark.parametrize("command", [["install", "--config", "robot"], ["status"], ["uninstall"]])
def test_without_systemd_the_service_commands_refuse_with_the_fix(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, command: list[str]
) -> None:
    monkeypatch.setattr(service, "SYSTEMD_RUN_DIR", tmp_path / "no-systemd")
    result = CliRunner().invoke(cli, ["service", *command])
    assert result.exit_code == 1
    assert "systemd is not running on this machine" in result.output and "fix:" in result.output
