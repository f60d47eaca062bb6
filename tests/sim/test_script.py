"""Scenario scripts: times, matching, and errors that name the line and the fix."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from cyborg.errors import ConfigError
from cyborg.interfaces.cli import cli
from cyborg.sim.script import Match, parse_script, parse_seconds


@pytest.mark.parametrize(
    ("value", "seconds"), [(90, 90.0), (1.5, 1.5), ("0:01:30", 90.0), ("2:00:00", 7200.0)]
)
def test_times(value: object, seconds: float) -> None:
    assert parse_seconds(value) == seconds


@pytest.mark.parametrize("value", ["ninety", -5, "1:75:00", True])
def test_bad_times(value: object) -> None:
    with pytest.raises(ValueError, match=r"use seconds|use 0 or more"):
        parse_seconds(value)


def test_match_by_type_text_and_fields() -> None:
    match = Match.model_validate({"type": "state", "to": "idle"})
    assert match.matches({"t": 1, "type": "state", "event": "succeeded", "from": "music", "to": "idle"})
    assert not match.matches({"t": 1, "type": "state", "event": "x", "from": "idle", "to": "music"})
    said = Match.model_validate({"type": "say", "contains": "SHOW YOU"})
    assert said.matches({"t": 2, "type": "say", "text": "would you like me to show you?"})


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            "until: 10\nsteps:\n  - at: 5\n    say: hi\n  - at: 7\n    sya: x\n",
            "line 5: step 2 sya: unknown key 'sya'",
        ),
        (
            "until: 10\nsteps:\n  - at: 5\n    say: hi\n    event: music_play\n",
            "line 3: step 1: give exactly one action",
        ),
        ("until: 10\nsteps:\n  - say: hi\n", "line 3: step 1: give exactly one of 'at'"),
        ("until: 10\nsteps:\n  - when: {type: sing}\n    say: hi\n", "unknown record type 'sing'"),
        ("steps: []\n", "missing 'until'"),
        ("until: soon\n", "'soon' is not a time"),
    ],
)
def test_bad_scripts_name_the_line_and_the_fix(text: str, expected: str) -> None:
    with pytest.raises(ConfigError) as info:
        parse_script(text, "s.yaml")
    assert expected in str(info.value) and "s.yaml" in str(info.value)


def test_cli_reports_a_bad_script(tmp_path: Path) -> None:
    script = tmp_path / "bad.yaml"
    script.write_text("until: 10\nsteps:\n  - at: 1\n    shout: hi\n")
    result = CliRunner().invoke(cli, ["sim", "--script", str(script), "--speed", "max"])
    assert result.exit_code == 1
    assert "bad.yaml: line 3: step 1 shout: unknown key 'shout'" in result.output
