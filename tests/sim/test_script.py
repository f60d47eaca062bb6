"""Scenario scripts: times, matching, and errors that name the line and the fix."""

from __future__ import annotations

import itertools
import json
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from cyborg.cli import cli
from cyborg.errors import ConfigError
from cyborg.sim.script import Match, parse_script, parse_seconds
from tests.support.tools import CYBORG_SCRIPT


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
        (
            "until: 10\ncalendar:\n  - {location: cafeteria, start: soon, end: 2026-11-23T16:00:00}\n",
            "line 3: calendar entry 1 start: 'soon' is not a date-time; fix: write it as 2026-11-23T15:00:00",
        ),
        (
            "until: 10\ncalendar:\n  - location: cafeteria\n    start: 2026-11-23T16:00:00\n"
            "    end: 2026-11-23T15:00:00\n",
            "line 3: calendar entry 1: end 2026-11-23T15:00:00 is not after start",
        ),
        (
            "until: 10\ncalendar:\n  - {start: 2026-11-23T15:00:00, end: 2026-11-23T16:00:00}\n",
            "line 3: calendar entry 1 location: missing 'location'; fix: add it (e.g. location: cafeteria)",
        ),
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


@pytest.mark.parametrize(
    ("steps", "expected"),
    [
        (
            "  - at: 1\n    event: musc_play\n",
            "line 3: step 1: event 'musc_play' is no transition of this state machine; fix: use one of",
        ),
        (
            "  - at: 1\n    emotion: joyful\n",
            "line 3: step 1: 'joyful' is no emotion of this robot; fix: use one of",
        ),
    ],
)
def test_cli_refuses_events_and_emotions_the_robot_does_not_know(
    tmp_path: Path, steps: str, expected: str
) -> None:
    script = tmp_path / "typo.yaml"
    script.write_text("until: 10\nsteps:\n" + steps)
    result = CliRunner().invoke(cli, ["sim", "--script", str(script), "--speed", "max"])
    assert result.exit_code == 1, result.output
    assert f"typo.yaml: {expected}" in result.output
    assert "music_play" in result.output or "elated" in result.output  # the fix lists the known names


def test_calendar_entry_at_an_unknown_place_names_its_line(tmp_path: Path) -> None:
    script = tmp_path / "cal.yaml"
    script.write_text(
        "until: 10\ncalendar:\n  - {location: cafeteria, start: 2026-11-23T15:00:00, end: 2026-11-23T16:00:00}\n"
        "  - {location: moon base, start: 2026-11-23T15:00:00, end: 2026-11-23T16:00:00}\n"
    )
    result = CliRunner().invoke(cli, ["sim", "--script", str(script), "--speed", "max"])
    assert result.exit_code == 1, result.output
    assert "cal.yaml: line 4: calendar entry 2:" in result.output and "moon base" in result.output


def test_transcript_ends_a_trip_with_the_arrival_pose(tmp_path: Path) -> None:
    from cyborg.app.config import load_config, packaged_config
    from cyborg.sim.base import SimulatedBase
    from cyborg.sim.scenario import ScenarioRun

    script = parse_script(
        "until: 400\nsteps:\n  - at: 1\n    say: go to the cafeteria\n"
        "  - when: {type: say, contains: 'Shall I go'}\n    say: 'yes'\n"
    )
    run = ScenarioRun(load_config(packaged_config("cyborg.yaml")), script, data_dir=tmp_path)
    base = next(c for c in run.robot.components.values() if isinstance(c, SimulatedBase))
    at_arrival: list[tuple[float, float]] = []

    def snapshot(record: dict[str, object]) -> None:
        if record["type"] == "state" and record["from"] == "navigation_moving" and not at_arrival:
            at_arrival.append((round(base.x, 3), round(base.y, 3)))

    run.listeners.append(snapshot)
    records = run.run()
    arrived = next(r for r in records if r["type"] == "state" and r["from"] == "navigation_moving")
    assert arrived["event"] == "succeeded"
    poses = [r for r in records if r["type"] == "pose"]
    assert all(b["t"] - a["t"] >= 0.999 for a, b in itertools.pairwise(poses)), "at most one a second"
    around = [(r["x"], r["y"]) for r in poses if arrived["t"] - 1.0 <= r["t"] <= arrived["t"] + 1.0]
    assert at_arrival[0] in around, "the arrival pose is recorded"


@pytest.mark.slow  # about 13 s: a subprocess runs wander trips until it has printed 400 lines
def test_ctrl_c_stops_a_scripted_day_cleanly_with_its_transcript(tmp_path: Path) -> None:
    """Ctrl-C in the terminal (SIGINT to the whole process group): the run stops where it is, says
    how many records it wrote (all of them in the transcript), leaves no traceback and no process."""
    script, transcript = tmp_path / "day.yaml", tmp_path / "day.jsonl"
    script.write_text("until: 28800\n")
    cyborg = CYBORG_SCRIPT
    env = {**os.environ, "CYBORG_DATA_DIR": str(tmp_path / "data")}
    args = [str(cyborg), "sim", "--script", str(script), "--speed", "max", "--transcript", str(transcript)]
    errors = (tmp_path / "stderr.txt").open("w+")  # a file: the log must not fill a pipe nobody reads
    process = subprocess.Popen(
        args, stdout=subprocess.PIPE, stderr=errors, text=True, env=env, start_new_session=True
    )
    assert process.stdout is not None
    lines = [process.stdout.readline() for _ in range(400)]  # several wander trips: the worker runs
    assert any("navigation_start_wandering" in line for line in lines), lines
    os.killpg(process.pid, signal.SIGINT)
    out, _ = process.communicate(timeout=60)
    errors.seek(0)
    err = errors.read()
    errors.close()
    assert process.returncode == 0, err
    assert "Traceback" not in err and "never retrieved" not in err and "destroyed" not in err, err
    said = re.search(r"stopped \(Ctrl-C\); wrote (\d+) records to", out)
    assert said is not None, out[-500:]
    records = [json.loads(line) for line in transcript.read_text().splitlines()]
    assert len(records) == int(said.group(1)) > 60
    assert records[-1]["t"] < 28800
    with pytest.raises(ProcessLookupError):  # nothing of the group is left
        for _ in range(50):
            os.killpg(process.pid, 0)
            time.sleep(0.1)
