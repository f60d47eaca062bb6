"""cyborg validate knows the whole robot: unserved states, resources of no module, phrases heard twice."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from click.testing import CliRunner
from pydantic import Field

from cyborg.app.checks import robot_warnings
from cyborg.app.config import parse_config
from cyborg.app.registry import module_kinds
from cyborg.cli import cli
from cyborg.modules import ModuleKind, ModuleSettings

MACHINE = """
initial: idle
timeouts: {connect: 1.0, preempt: 1.0}
states:
  idle: {action: cyborg_idle/idle, transitions: {conversation_interest: conversation, greeting_heard: greeting, aborted: idle}}
  conversation: {action: cyborg_conversation/conversation, transitions: {succeeded: idle, aborted: idle}}
  greeting:
    action: greeter/greet
    transitions: {succeeded: idle, aborted: idle}
    resources: {speech: greeter}
  joke:
    action: cyborg_joke/tell
    transitions: {succeeded: idle, aborted: idle}
    resources: {speech: cyborg_jokes}
modules:
  cyborg_idle: {kind: idle}
  cyborg_conversation: {kind: conversation}
  greeter: {kind: greeter}
"""


class GreeterSettings(ModuleSettings):
    """Answers good morning."""

    action: str = Field("greeter/greet", description="action server of the greeting state")

    def listens_for(self) -> tuple[str, ...]:
        return ("Good morning",)


GREETER: ModuleKind[Any] = ModuleKind(GreeterSettings, lambda node, settings, context: None)  # type: ignore[arg-type,return-value]


def warnings(text: str) -> list[str]:
    return robot_warnings(parse_config(text, source="robot.yaml"), module_kinds({"greeter": GREETER}))


def test_the_whole_robot_is_checked() -> None:
    found = warnings(MACHINE)
    assert len(found) == 3, found
    unserved, holder, race = found
    assert unserved.startswith("state 'joke': no module in this file serves its action 'cyborg_joke/tell'")
    assert (
        "fix: add a module that serves it (e.g. {kind: placeholder, servers: [{action: cyborg_joke/tell}]})"
        in unserved
    )
    assert holder.startswith(
        "state 'joke': resource 'speech' goes to 'cyborg_jokes', which is no module's node"
    )
    assert "cyborg_conversation, cyborg_idle, greeter" in holder
    assert race.startswith("modules 'cyborg_conversation' and 'greeter' both listen for 'good morning'")


def test_a_robot_without_modules_gets_no_such_warnings() -> None:
    without = MACHINE.split("modules:")[0]
    assert warnings(without) == []


def test_cyborg_validate_prints_the_warnings_and_still_says_valid(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text(
        MACHINE.replace("  greeter: {kind: greeter}\n", "").replace("greeter/greet", "cyborg_idle/idle")
    )
    result = CliRunner().invoke(cli, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    assert "warning: state 'joke': no module in this file serves its action" in result.output
    assert "resource 'speech' goes to 'greeter', which is no module's node" in result.output
    assert f"{path}: valid" in result.output
