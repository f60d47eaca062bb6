"""Virtual time is for a simulated base: a configuration that drives a real base runs in real time."""

from __future__ import annotations

from click.testing import CliRunner

from cyborg.cli import cli


def test_the_real_robot_refuses_virtual_time_and_says_what_to_do() -> None:
    for speed in ("max", "20"):
        result = CliRunner().invoke(cli, ["launch", "--config", "robot", "--speed", speed])
        assert result.exit_code != 0
        assert "drives a real base" in result.output and "fix: drop --speed" in result.output, result.output
