"""Scenario scripts that check: expect steps, and when steps that never fire, fail the run."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from click.testing import CliRunner

from cyborg.app.config import load_config, packaged_config
from cyborg.cli import cli
from cyborg.errors import ConfigError, ScenarioFailed
from cyborg.observe.records import Record
from cyborg.sim.scenario import run_scenario
from cyborg.sim.script import parse_script

GREETING = """
until: 120
steps:
  - {at: 5, say: hello}
  - expect: {type: state, to: conversation}
    within: 5
  - {expect: {type: say}, within: 30}
"""


def run(text: str) -> list[Record]:
    return run_scenario(load_config(packaged_config("cyborg.yaml")), parse_script(text, source="test.yaml"))


def test_met_expectations_let_the_run_go_on_to_its_end() -> None:
    records = run(GREETING)
    assert records[-1]["t"] > 60, "the run went on after the last expectation"


def test_an_unmet_expectation_fails_naming_its_line_and_what_came_instead() -> None:
    text = GREETING.replace("{type: say}, within: 30", "{type: say, contains: goodbye}, within: 30")
    with pytest.raises(ScenarioFailed) as caught:
        run(text)
    (problem,) = caught.value.problems
    assert problem.startswith("line 7: step 3 expected {type: say, contains: goodbye} within 30 s")
    assert "instead: " in problem and " say '" in problem, "it names the sentences said instead"
    assert str(caught.value).startswith("test.yaml: line 7")


def test_a_when_that_never_fires_fails_the_run() -> None:
    text = """
until: 60
steps:
  - when: {type: state, to: music}
    say: hello
"""
    with pytest.raises(
        ScenarioFailed, match=r"line 4: step 1 waited for \{type: state, to: music\}, which never came"
    ):
        run(text)


def test_a_state_that_never_came_is_told_with_the_motivators_last_decision() -> None:
    text = """
until: 60
steps:
  - when: {type: state, event: succeeded, from: music}
    say: hello
"""
    with pytest.raises(ScenarioFailed) as caught:
        run(text)
    (problem,) = caught.value.problems
    # It wandered the whole minute: the motivator says why it moved the robot on no further.
    assert "navigation_moving" in problem
    assert (
        "(the motivator's last decision, at t=60: no motivational events in state 'navigation_moving')"
        in problem
    )


def test_cyborg_sim_exits_1_on_a_failed_expectation(tmp_path: Path) -> None:
    script = tmp_path / "s.yaml"
    script.write_text(GREETING.replace("to: conversation}", "to: music}"))
    result = CliRunner().invoke(cli, ["sim", "--script", str(script), "--speed", "max"])
    assert result.exit_code == 1
    assert "line 5: step 2 expected {type: state, to: music} within 5 s" in result.output
    assert "--conversation_interest--> conversation" in result.output, "what came instead"


@pytest.mark.parametrize(
    ("step", "message"),
    [
        ("{expect: {type: state}, say: hi}", r"an 'expect' step only checks, so it takes no 'say'"),
        ("{at: 3, say: hi, within: 4}", r"'within' goes with 'expect'"),
        ("{expect: {type: nonsense}}", r"unknown record type 'nonsense'"),
    ],
)
def test_bad_expect_steps_are_refused_with_the_fix(step: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_script(f"until: 10\nsteps:\n  - {step}\n")


def test_a_run_that_ends_while_the_robot_wanders_ends_without_a_warning(
    caplog: pytest.LogCaptureFixture,
) -> None:
    records = run("seed: 7\nuntil: 30\nsteps: []\n")
    states = [r for r in records if r["type"] == "state"]
    assert states[-1]["to"] == "navigation_moving", "it was wandering at the end"
    problems = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert problems == [], problems


def test_records_of_the_same_loop_turn_after_a_match_are_seen_by_the_next_step() -> None:
    # At t=5 the robot hears 'hello' and enters conversation in one loop turn: the state record
    # comes right after the heard record that met step 2, and step 3 must see it.
    text = """
until: 20
steps:
  - {at: 5, say: hello}
  - {expect: {type: heard, text: hello}, within: 1}
  - {expect: {type: state, to: conversation}, within: 1}
"""
    records = run(text)
    assert records[-1]["t"] >= 19, "the run went on to its end"
