"""The thesis's four scenarios (10.2) run on the default robot in virtual time (embedded transport).

Each asserts the sequence of states and the sentences spoken (see expectations.py).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from expectations import CHECKS, Record

from cyborg.controller.config import load_config
from cyborg.interfaces.cli import packaged_config
from cyborg.sim.scenario import run_scenario
from cyborg.sim.script import load_script

HERE = Path(__file__).parent


def run(name: str, tmp_path: Path) -> list[Record]:
    transcript = tmp_path / f"{name}.jsonl"
    with transcript.open("w") as out:
        records = run_scenario(
            load_config(packaged_config("cyborg.yaml")), load_script(HERE / f"{name}.yaml"), transcript=out
        )
    lines = [json.loads(line) for line in transcript.read_text().splitlines()]
    assert lines == records  # the transcript holds exactly what happened
    return records


@pytest.mark.parametrize("name", sorted(CHECKS))
def test_scenario(name: str, tmp_path: Path) -> None:
    CHECKS[name](run(name, tmp_path))


def test_same_script_same_transcript(tmp_path: Path) -> None:
    (tmp_path / "1").mkdir()
    (tmp_path / "2").mkdir()
    assert run("scenario_d", tmp_path / "1") == run("scenario_d", tmp_path / "2")
