"""Issue 30, item 3: failed steps name what dropped or broke the expected thing; expect_not; the
summary of a passing script."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from cyborg.app.config import load_config, packaged_config
from cyborg.cli import cli
from cyborg.errors import ConfigError, ScenarioFailed
from cyborg.modules import BehaviourModule, GoalContext
from cyborg.sim.scenario import ScenarioRecords, ScenarioRun, run_scenario
from cyborg.sim.script import parse_script
from cyborg.sim.witness import Witness
from cyborg.transport.base import GoalStatus, Node
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import StateMachineAction, StateMachineGoal, String


def run(text: str) -> ScenarioRecords:
    return run_scenario(load_config(packaged_config("cyborg.yaml")), parse_script(text, source="t.yaml"))


def failure(text: str) -> str:
    with pytest.raises(ScenarioFailed) as caught:
        run(text)
    (problem,) = caught.value.problems
    return problem


def test_a_passing_script_tells_how_many_expectations_it_met(tmp_path: Path) -> None:
    text = """
until: 30
steps:
  - {at: 5, say: hello}
  - {expect: {type: state, to: conversation}, within: 5}
  - {expect_not: {type: state, to: music}, within: 5}
"""
    assert run(text).summary == "2 of 2 expectations met"
    script = tmp_path / "s.yaml"
    script.write_text(text, encoding="utf-8")
    result = CliRunner().invoke(cli, ["sim", "--script", str(script), "--speed", "max"])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1] == "2 of 2 expectations met"


def test_the_first_step_sees_the_records_of_the_start() -> None:
    text = "until: 5\nsteps:\n  - {expect: {type: state, to: idle}, within: 1}\n"
    assert run(text).summary == "1 of 1 expectation met"


def test_expect_not_fails_naming_the_record_that_came() -> None:
    problem = failure(
        """
until: 30
steps:
  - {at: 5, say: hello}
  - {expect_not: {type: state, to: conversation}, within: 5}
"""
    )
    assert problem == (
        "line 5: step 2 expected no {type: state, to: conversation} within 5 s (from t=5.0 s); "
        "instead: t=5 idle --conversation_interest--> conversation"
    )


def test_expect_not_without_within_watches_until_the_end() -> None:
    assert run("until: 8\nsteps:\n  - expect_not: {type: say}\n").summary == "1 of 1 expectation met"
    assert "expected no {type: state, to: conversation} before the end" in failure(
        "until: 8\nsteps:\n  - {at: 5, say: hello}\n  - expect_not: {type: state, to: conversation}\n"
    )


@pytest.mark.parametrize(
    ("step", "message"),
    [
        ("{expect_not: {type: state}, say: hi}", r"an 'expect_not' step only checks, so it takes no 'say'"),
        ("{expect_not: {type: say}, expect: {type: say}}", r"'expect' or 'expect_not', not both; fix: "),
        ("{expect_not: {type: nonsense}}", r"unknown record type 'nonsense'; fix: use one of"),
    ],
)
def test_bad_expect_not_steps_are_refused_with_the_fix(step: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_script(f"until: 10\nsteps:\n  - {step}\n")


def test_a_dropped_event_is_named_instead_of_the_motivator() -> None:
    problem = failure(
        """
until: 30
steps:
  - {at: 5, event: navigation_wandering_completed}
  - {expect: {type: state, event: navigation_wandering_completed}, within: 3}
"""
    )
    assert problem.endswith(
        "instead: no state record at all; in that window: t=5 event 'navigation_wandering_completed' "
        "from cyborg_scenario was dropped by the controller: it is no transition of 'idle' (its events: "
        "aborted, conversation_interest, music_play, navigation_command, navigation_emotional, "
        "navigation_scheduler)"
    ), problem
    assert "motivator" not in problem, "the motivator had nothing to do with it"


def test_a_sentence_the_gatekeeper_dropped_is_named_with_the_grant_it_lacked(tmp_path: Path) -> None:
    script = parse_script(
        "until: 20\nsteps:\n  - {at: 5, say: what time is it}\n"
        "  - {expect: {type: say, contains: It is}, within: 2}\n",
        source="t.yaml",
    )
    scenario = ScenarioRun(load_config(packaged_config("cyborg.yaml")), script, data_dir=tmp_path)
    speech = scenario.transport.node("time_teller").publisher("/text_to_speech", String)
    scenario.clock.call_later(5.5, lambda: speech.publish(String("It is 15:29.")))
    with pytest.raises(ScenarioFailed) as caught:
        scenario.run()
    (problem,) = caught.value.problems
    assert problem.endswith(
        "instead: no say record at all; in that window: t=5.5 cyborg_speech_gatekeeper dropped "
        "'It is 15:29.' from time_teller: speech is held by nobody; fix: grant it in the state, "
        "resources: {speech: time_teller}"
    ), problem


def test_a_module_that_crashed_is_noted_with_its_exception() -> None:
    """A module goal that raises is reported on its diagnostic topic: the witness hears it over
    any transport (here the embedded one), not only in the robot's own process."""

    class TimeTeller(BehaviourModule):
        def __init__(self, node: Node) -> None:
            super().__init__(node)
            self.serve("time_teller/tell", self.tell)

        async def tell(self, ctx: GoalContext) -> None:
            print("It is " + 5)  # type: ignore[operator]  # the newcomer's mistake 3

    clock = VirtualClock(speed=None)
    transport = EmbeddedTransport(clock)
    witness = Witness(transport.node("cyborg_scenario"))
    TimeTeller(transport.node("time_teller"))
    client = transport.node("controller").action_client("time_teller/tell", StateMachineAction)

    async def main() -> GoalStatus:
        handle = client.send_goal(StateMachineGoal("idle", "tell_time", "telling"))
        await handle.wait()
        await clock.sleep(0.1)  # the report arrives on the loop
        return handle.status

    try:
        assert clock.run(main()) is GoalStatus.ABORTED
    finally:
        transport.shutdown()
        clock.close()
    assert [note.text for note in witness.notes] == [
        'time_teller crashed (TypeError: can only concatenate str (not "int") to str); '
        "its state (time_teller/tell) ended 'aborted'"
    ]
