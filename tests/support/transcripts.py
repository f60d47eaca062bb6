"""The records a ROS run of a scenario must share with the robot in one process.

Lockstep time (docs/lockstep.md) makes a graph of processes run a script the way one process
does: the state, say, heard and emotion records are the same, to the nanosecond. Pose records
are left out: over ROS they are what the scenario's node received, in one process what the base
published, and the base's last steps before a stop may fall on either side.
"""

from __future__ import annotations

import functools
import json
import tempfile
from pathlib import Path
from typing import Any

from cyborg.app.config import load_config, packaged_config
from cyborg.sim.scenario import run_scenario
from cyborg.sim.script import load_script
from tests.support.paths import SCENARIOS

SHARED = ("state", "say", "heard", "emotion")

Record = dict[str, Any]


@functools.cache
def in_process(name: str) -> tuple[str, ...]:
    """Scenario ``name``'s shared records in one process (computed once per test process)."""
    with tempfile.TemporaryDirectory(prefix="cyborg-in-process-") as folder:
        transcript = Path(folder) / "transcript.jsonl"
        with transcript.open("w") as out:
            run_scenario(
                load_config(packaged_config("cyborg.yaml")),
                load_script(SCENARIOS / f"{name}.yaml"),
                transcript=out,
                data_dir=Path(folder) / "data",
            )
        return shared([json.loads(line) for line in transcript.read_text().splitlines()])


def shared(records: list[Record]) -> tuple[str, ...]:
    return tuple(json.dumps(r, sort_keys=True) for r in records if r["type"] in SHARED)


def assert_same_as_in_process(name: str, records: list[Record]) -> None:
    """The run's shared records are those of the run in one process; else name the first difference."""
    ours, theirs = shared(records), in_process(name)
    for index, (got, wanted) in enumerate(zip(ours, theirs, strict=False)):
        assert got == wanted, f"record {index} differs from the run in one process:\n  {got}\n  {wanted}"
    assert len(ours) == len(theirs), f"{len(ours)} shared records, {len(theirs)} in one process"
