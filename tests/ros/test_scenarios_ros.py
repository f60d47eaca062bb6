"""The thesis's four scenarios (10.2) over ROS: every part its own `cyborg node` process.

``cyborg sim --ros --script FILE --speed max`` (run here as a user runs it) starts the robot's
nodes and the ``cyborg_scenario`` node on the session's roscore, in lockstep time (the launch's
time server grants the next timer once every node is idle and every message has arrived, so a
loaded machine changes nothing but the wall time); the simulated base publishes that time on
/clock. The transcript must pass the same checks as the embedded run
(tests/scenarios/expectations.py), and its state, say, heard and emotion records must be the
embedded run's, to the nanosecond (tests/support/transcripts.py).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from datetime import UTC
from pathlib import Path

import pytest

from cyborg.sim.scenario import script_start
from cyborg.sim.script import load_script
from tests.scenarios.expectations import check_transcript
from tests.support.paths import SCENARIOS
from tests.support.ros import Observers, RosSession
from tests.support.transcripts import assert_same_as_in_process


@pytest.mark.parametrize("name", ["scenario_a", "scenario_b", "scenario_c", "scenario_d"])
def test_scenario_over_ros(name: str, ros: RosSession, observe: Observers, tmp_path: Path) -> None:
    from rosgraph_msgs.msg import Clock  # type: ignore[import-not-found]

    script_path = SCENARIOS / f"{name}.yaml"
    script = load_script(script_path)
    clock = observe.topic("/clock", Clock)
    transcript = tmp_path / "transcript.jsonl"
    command = [sys.executable, "-m", "cyborg.cli", "sim", "--ros", "--script", str(script_path)]
    command += ["--speed", "max", "--transcript", str(transcript), "--db", str(tmp_path / "data")]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    records = [json.loads(line) for line in transcript.read_text().splitlines()]
    check_transcript(name, records, transcript)
    assert_same_as_in_process(name, records)
    assert records[-1]["t"] <= script.until + 1

    # Simulated time on /clock, from the simulated base, starting at the script's start.
    assert clock.heard, "nothing was published on /clock"
    assert {h.sender for h in clock.heard} == {"rosarnl_node"}
    stamps = [h.message.clock.to_sec() for h in clock.heard]
    assert stamps == sorted(stamps)
    start = script_start(script).astimezone(UTC).timestamp()
    assert start <= stamps[0] < start + 60
    assert stamps[-1] - stamps[0] >= 0.8 * script.until
    assert "in lockstep" in result.stdout and f"wrote {len(records)} records" in result.stdout
    assert "written off" not in result.stdout + result.stderr, "every message was counted in and out"
    assert re.search(r"cyborg_scenario: (\d+) of \1 expectations? met", result.stdout), result.stdout[-2000:]
