"""Transition lookup and the state hierarchy (pure logic)."""

from __future__ import annotations

from cyborg.app.config import parse_config

NESTED = """
initial: idle
states:
  idle:
    action: cyborg_idle/idle
    transitions: {navigation_command: navigation, aborted: idle, talk: talking}
  navigation:
    initial: planning
    transitions: {aborted: idle, conversation_interest: idle}
    resources: {base: cyborg_navigation}
    states:
      planning:
        action: cyborg_navigation/planning
        transitions: {start_moving: moving}
      moving:
        action: cyborg_navigation/moving
        transitions: {succeeded: talking, aborted: talking}
        resources: {speech: cyborg_navigation}
      talking:
        action: cyborg_navigation/talking
        transitions: {succeeded: idle}
"""


def test_own_transition_is_found() -> None:
    machine = parse_config(NESTED).machine
    assert machine.lookup("planning", "start_moving") == "moving"


def test_superstate_transition_applies_to_every_substate() -> None:
    machine = parse_config(NESTED).machine
    for sub in ("planning", "moving", "talking"):
        assert machine.lookup(sub, "conversation_interest") == "idle"


def test_own_transition_wins_over_the_superstates() -> None:
    machine = parse_config(NESTED).machine
    assert machine.lookup("moving", "aborted") == "talking"
    assert machine.lookup("planning", "aborted") == "idle"


def test_targeting_a_superstate_enters_its_initial_substate() -> None:
    machine = parse_config(NESTED).machine
    assert machine.lookup("idle", "navigation_command") == "planning"


def test_unknown_event_is_no_transition() -> None:
    machine = parse_config(NESTED).machine
    assert machine.lookup("idle", "start_moving") is None
    assert machine.lookup("planning", "nonsense") is None


def test_resources_are_inherited_and_merged() -> None:
    machine = parse_config(NESTED).machine
    assert machine.resources_of("moving") == {"speech": "cyborg_navigation", "base": "cyborg_navigation"}
    assert machine.resources_of("planning") == {"base": "cyborg_navigation"}
    assert machine.resources_of("idle") == {}


def test_transitions_of_lists_inherited_events() -> None:
    machine = parse_config(NESTED).machine
    assert machine.transitions_of("talking") == {
        "succeeded": "idle",
        "aborted": "idle",
        "conversation_interest": "idle",
    }
