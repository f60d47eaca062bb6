"""A module whose factory raises is reported in one line naming it, the reason and the fix."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from pydantic import Field

import cyborg.app.registry
import cyborg.app.robot
from cyborg.app.config import parse_config
from cyborg.app.context import BuildContext
from cyborg.app.parts import build_part
from cyborg.app.registry import module_kinds
from cyborg.app.robot import build_robot
from cyborg.cli import cli
from cyborg.errors import ConfigError
from cyborg.modules import Component, ModuleKind, ModuleSettings, Node
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport

MACHINE = """
initial: idle
states:
  idle: {action: cyborg_idle/idle, transitions: {aborted: idle}}
modules:
  cyborg_idle: {kind: idle}
  time_teller: {kind: time_teller, timezone: Europe/Olso}
"""


class TimeTellerSettings(ModuleSettings):
    """Tells the time (its factory refuses an unknown time zone)."""

    timezone: str = Field("UTC", description="time zone")


def _build(node: Node, settings: TimeTellerSettings, context: object) -> Component:
    from zoneinfo import ZoneInfo

    ZoneInfo(settings.timezone)
    raise AssertionError("not reached in these tests")


TIME_TELLER: ModuleKind[Any] = ModuleKind(TimeTellerSettings, _build)  # type: ignore[arg-type]
EXPECTED = (
    "robot.yaml: line 7: module 'time_teller' could not be built: ZoneInfoNotFoundError: "
    "'No time zone found with key Europe/Olso'; fix: correct its settings under modules: time_teller"
)


def test_the_in_process_robot_names_the_module_that_could_not_be_built(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    config = parse_config(MACHINE, source="robot.yaml")
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    try:
        with (
            caplog.at_level(logging.DEBUG, logger="cyborg.app.registry"),
            pytest.raises(ConfigError) as raised,
        ):
            build_robot(
                config, transport, data_dir=tmp_path, kinds=module_kinds({"time_teller": TIME_TELLER})
            )
    finally:
        transport.shutdown()
        clock.close()
    assert len(str(raised.value).splitlines()) == 1
    assert str(raised.value).startswith(EXPECTED)
    assert any(record.exc_info for record in caplog.records), "the traceback goes to the debug log"


def test_a_ros_node_part_names_the_module_that_could_not_be_built(tmp_path: Path) -> None:
    config = parse_config(MACHINE, source="robot.yaml")
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    context = BuildContext(data_dir=tmp_path)
    try:
        with pytest.raises(ConfigError) as raised:
            build_part(
                "time_teller", config, transport, context, kinds=module_kinds({"time_teller": TIME_TELLER})
            )
    finally:
        transport.shutdown()
        clock.close()
    assert str(raised.value).startswith(EXPECTED)


def test_cyborg_sim_says_it_in_one_line_and_exits_1(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def kinds(extra: Any = None) -> Any:
        return cyborg.app.registry.KindRegistry(extra={"time_teller": TIME_TELLER, **(extra or {})})

    monkeypatch.setattr(cyborg.app.registry, "module_kinds", kinds)
    monkeypatch.setattr(cyborg.app.robot, "module_kinds", kinds)
    path = tmp_path / "robot.yaml"
    path.write_text(MACHINE)
    result = CliRunner().invoke(
        cli,
        [
            "sim",
            "--config",
            str(path),
            "--speed",
            "max",
            "--duration",
            "1",
            "--port",
            "0",
            "--data-dir",
            str(tmp_path / "d"),
        ],
    )
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output
    assert f"{path}: line 7: module 'time_teller' could not be built: ZoneInfoNotFoundError" in result.output
