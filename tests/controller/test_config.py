"""Validation of the state machine YAML: every error names the state and the fix."""

from __future__ import annotations

from pathlib import Path

import pytest

from cyborg.controller.config import load_config, parse_config
from cyborg.errors import ConfigError

VALID = """
states:
  idle:
    action: cyborg_idle/idle
    transitions: {music_play: music, aborted: idle}
  music:
    action: cyborg_music/play
    transitions: {succeeded: idle, aborted: idle}
"""


def problems(text: str) -> str:
    with pytest.raises(ConfigError) as info:
        parse_config(text, source="machine.yaml")
    return str(info.value)


def test_valid_file_defaults_initial_to_idle() -> None:
    loaded = parse_config(VALID)
    assert loaded.machine.initial == "idle"
    assert loaded.machine.timeouts.connect == 2.0
    assert loaded.warnings == []


def test_unknown_target_names_state_and_suggests() -> None:
    text = VALID.replace("music_play: music", "music_play: musik")
    message = problems(text)
    assert "machine.yaml" in message
    assert "state 'idle'" in message
    assert "unknown state 'musik'" in message
    assert "did you mean 'music'" in message


def test_missing_aborted_transition() -> None:
    text = VALID.replace("{succeeded: idle, aborted: idle}", "{succeeded: idle}")
    message = problems(text)
    assert "state 'music'" in message and "no 'aborted' transition" in message and "fix:" in message


def test_aborted_inherited_from_superstate_is_enough() -> None:
    text = """
states:
  idle: {action: a/idle, transitions: {go: group, aborted: idle}}
  group:
    transitions: {aborted: idle}
    states:
      inner: {action: a/inner}
"""
    assert parse_config(text).machine.lookup("inner", "aborted") == "idle"


def test_duplicate_state_key_is_reported_with_line() -> None:
    text = (
        VALID
        + """
  idle:
    action: other/idle
    transitions: {aborted: idle}
"""
    )
    message = problems(text)
    assert "duplicate key 'idle'" in message and "line" in message


def test_duplicate_state_across_levels() -> None:
    text = """
states:
  idle: {action: a/idle, transitions: {aborted: idle, go: group}}
  group:
    transitions: {aborted: idle}
    states:
      idle: {action: b/idle}
"""
    assert "state 'idle': defined twice" in problems(text)


def test_wrong_types_are_named() -> None:
    text = VALID.replace("transitions: {music_play: music, aborted: idle}", "transitions: [music]")
    message = problems(text)
    assert "state 'idle' > transitions" in message


def test_unknown_key_is_named() -> None:
    message = problems(VALID.replace("action: cyborg_music/play", "action: cyborg_music/play\n    actoin: x"))
    assert "unknown key 'actoin'" in message


def test_timeouts_must_be_positive() -> None:
    message = problems("timeouts: {connect: -1}\n" + VALID)
    assert "timeouts > connect" in message


def test_unknown_initial_state() -> None:
    message = problems("initial: idel\n" + VALID)
    assert "initial state 'idel'" in message and "did you mean 'idle'" in message


def test_state_without_action_or_substates() -> None:
    message = problems(VALID.replace("action: cyborg_music/play", "description: none"))
    assert "state 'music': has no action" in message


def test_all_problems_reported_at_once() -> None:
    text = VALID.replace("music_play: music", "music_play: nowhere").replace(
        "succeeded: idle, aborted: idle", "succeeded: gone"
    )
    message = problems(text)
    assert "'nowhere'" in message and "'gone'" in message


def test_unreachable_state_is_a_warning_not_an_error() -> None:
    text = (
        VALID
        + """
  lonely:
    action: cyborg_lonely/x
    transitions: {aborted: idle}
"""
    )
    loaded = parse_config(text, source="m.yaml")
    assert any("'lonely' is unreachable" in w for w in loaded.warnings)


def test_bad_yaml_syntax() -> None:
    assert "not valid YAML" in problems("states: {idle: [")


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read the file"):
        load_config(tmp_path / "missing.yaml")


def test_packaged_configs_are_valid() -> None:
    from cyborg.interfaces.cli import packaged_config

    for name in ("demo.yaml",):
        assert load_config(packaged_config(name)).machine.states


def test_motivational_event_must_be_a_transition_of_its_state() -> None:
    text = (
        VALID
        + """
motivator:
  events:
    - {state: idle, event: music_play, reward_pleasure: 0.1}
    - {state: music, event: dance, reward_arousal: 0.1}
    - {state: nowhere, event: music_play}
"""
    )
    message = problems(text)
    assert "motivator event 'dance' is no transition of state 'music'" in message
    assert "state 'nowhere' is not defined" in message
    assert "'music_play'" not in message.split("dance")[0]  # the valid one is not reported


def test_emotion_settings_are_validated() -> None:
    message = problems(VALID + "\nemotion: {decay_rate: 3}\n")
    assert "emotion > decay_rate" in message
