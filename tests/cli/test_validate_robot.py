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
    assert unserved.startswith(
        "line 12: state 'joke': no module in this file serves its action 'cyborg_joke/tell'"
    )
    assert (
        "fix: add a module that serves it (e.g. {kind: placeholder, servers: [{action: cyborg_joke/tell}]})"
        in unserved
    )
    assert holder.startswith(
        "line 14: state 'joke': resource 'speech' goes to 'cyborg_jokes', which is no module's node"
    )
    assert "cyborg_conversation, cyborg_idle, greeter" in holder
    assert race.startswith(
        "line 18: modules 'cyborg_conversation' and 'greeter' both listen for 'good morning'"
    )


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
    assert "warning: line 12: state 'joke': no module in this file serves its action" in result.output
    assert "resource 'speech' goes to 'greeter', which is no module's node" in result.output
    assert f"{path}: valid" in result.output and "warning(s) above" in result.output
    strict = CliRunner().invoke(cli, ["validate", "--strict", str(path)])
    assert strict.exit_code == 1, strict.output
    assert "warning(s) with --strict" in strict.output and f"{path}: valid" not in strict.output


TIME_TELLER_MACHINE = """
initial: idle
states:
  idle: {action: cyborg_idle/idle, transitions: {time_ask: time_telling, aborted: idle}}
  time_telling:
    action: time_teller/tel
    transitions: {succeeded: idle, aborted: idle}
modules:
  cyborg_idle: {kind: idle}
  time_teller: {kind: time_teller}
gatekeepers:
  - {name: cyborg_speech_gatekeeper, input: /text_to_speech, output: /cyborg_tts/say, resource: speech}
"""


class TimeTellerSettings(ModuleSettings):
    """Tells the time when asked."""

    action: str = Field("time_teller/tell", description="action server of the time-telling state")
    event: str = Field("time_asked", description="the event it publishes when asked")

    def publishes(self) -> tuple[str, ...]:
        return (self.event,)

    def speaks_in(self) -> tuple[str, ...]:
        return (self.action,)


TIME_TELLER: ModuleKind[Any] = ModuleKind(TimeTellerSettings, lambda node, settings, context: None)  # type: ignore[arg-type,return-value]


def time_teller_warnings(text: str) -> list[str]:
    return robot_warnings(parse_config(text, source="robot.yaml"), module_kinds({"time_teller": TIME_TELLER}))


def test_a_wrong_action_name_gets_did_you_mean_with_the_module_that_serves_it() -> None:
    found = time_teller_warnings(TIME_TELLER_MACHINE)
    [unserved] = [w for w in found if "no module in this file serves" in w]
    assert unserved.startswith(
        "line 6: state 'time_telling': no module in this file serves its action 'time_teller/tel' "
        "(did you mean 'time_teller/tell', served by module 'time_teller'?)"
    )
    assert "fix: correct it to 'time_teller/tell'" in unserved


def test_an_event_a_module_publishes_that_no_state_takes_is_named_with_the_fix() -> None:
    found = time_teller_warnings(TIME_TELLER_MACHINE.replace("time_teller/tel\n", "time_teller/tell\n"))
    [event] = [w for w in found if "publishes the event" in w]
    assert event.startswith(
        "line 10: module 'time_teller' publishes the event 'time_asked', which is no transition of any "
        "state, so the controller drops it; fix: did you mean the transition 'time_ask'? rename it to "
        "'time_asked'"
    )
    fixed = TIME_TELLER_MACHINE.replace("time_ask:", "time_asked:").replace(
        "time_teller/tel\n", "time_teller/tell\n"
    )
    assert not [w for w in time_teller_warnings(fixed) if "publishes the event" in w]


def test_a_module_that_speaks_in_a_state_without_the_speech_grant_is_warned_about() -> None:
    text = TIME_TELLER_MACHINE.replace("time_ask:", "time_asked:").replace(
        "time_teller/tel\n", "time_teller/tell\n"
    )
    [speech] = time_teller_warnings(text)
    assert speech == (
        "line 5: state 'time_telling': module 'time_teller' says things there, but the state grants "
        "'speech' to nobody, so cyborg_speech_gatekeeper drops its sentences; fix: add "
        "'resources: {speech: time_teller}' to state 'time_telling'"
    )
    granted = text.replace(
        "    transitions: {succeeded: idle, aborted: idle}\n",
        "    transitions: {succeeded: idle, aborted: idle}\n    resources: {speech: time_teller}\n",
    )
    assert time_teller_warnings(granted) == []


def test_the_packaged_robots_declare_what_they_publish_and_validate_without_warnings() -> None:
    from cyborg.app.config import load_config, packaged_config

    for name in ("cyborg.yaml", "demo.yaml", "monitor.yaml"):
        config = load_config(packaged_config(name))
        assert robot_warnings(config, module_kinds()) == [], name
    navigation = module_kinds().parse("cyborg_navigation", {"kind": "navigation"})[1]
    assert "navigation_start_moving" in navigation.publishes()
    conversation = module_kinds().parse("c", {"kind": "conversation"})[1]
    assert conversation.publishes() == ("conversation_interest",)
