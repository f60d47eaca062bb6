"""The thesis's four scenarios (10.2) over ROS: every part its own `cyborg node` process.

``cyborg sim --ros --script`` (:func:`run_scenario_ros`) starts the robot's nodes and the
``cyborg_scenario`` node on the session's roscore, in shared virtual time at SPEED times real
time; the simulated base publishes that time on /clock. The transcript must pass the same
checks as the embedded run (tests/scenarios/expectations.py).
"""

from __future__ import annotations

import importlib.util
import sys
from datetime import UTC
from pathlib import Path
from types import ModuleType

import pytest

from conftest import Observers, RosSession
from cyborg.controller.config import load_config
from cyborg.interfaces.cli import packaged_config
from cyborg.interfaces.ros_commands import run_scenario_ros
from cyborg.sim.scenario import script_start
from cyborg.sim.script import load_script

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
SPEED = 25.0  # virtual seconds per real second


def _expectations() -> ModuleType:
    name = "scenario_expectations"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, SCENARIOS / "expectations.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


@pytest.mark.parametrize("name", ["scenario_a", "scenario_b", "scenario_c", "scenario_d"])
def test_scenario_over_ros(name: str, ros: RosSession, observe: Observers, tmp_path: Path) -> None:
    from rosgraph_msgs.msg import Clock  # type: ignore[import-not-found]

    script_path = SCENARIOS / f"{name}.yaml"
    script = load_script(script_path)
    clock = observe.topic("/clock", Clock)
    lines: list[str] = []
    records = run_scenario_ros(
        packaged_config("cyborg.yaml"),
        load_config(packaged_config("cyborg.yaml")),
        script_path,
        transcript_path=tmp_path / "transcript.jsonl",
        speed=SPEED,
        data_dir=tmp_path / "data",
        map_path=None,
        say=lines.append,
    )
    _expectations().CHECKS[name](records)
    assert records[-1]["t"] <= script.until + 1

    # Simulated time on /clock, from the simulated base, starting at the script's start.
    assert clock.heard, "nothing was published on /clock"
    assert {h.sender for h in clock.heard} == {"rosarnl_node"}
    stamps = [h.message.clock.to_sec() for h in clock.heard]
    assert stamps == sorted(stamps)
    start = script_start(script).astimezone(UTC).timestamp()
    assert start <= stamps[0] < start + 60
    assert stamps[-1] - stamps[0] >= 0.8 * script.until
    assert any("virtual time" in line for line in lines)
