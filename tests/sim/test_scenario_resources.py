"""Issue 12, items 6 and 7: a scenario's transcript streams to disk, one robot per data folder,
and a full disk is reported as such."""

from __future__ import annotations

import errno
import json
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from cyborg.cli import cli
from cyborg.sim import scenario
from tests.support.tools import CYBORG_SCRIPT

SCRIPT = """\
until: 900
steps:
  - at: 5
    event: music_play
  - when: {type: state, to: music}
    delay: 30
    say: hello
"""


def test_cli_streams_the_transcript_and_keeps_no_records(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    drivers: list[scenario.ScenarioDriver] = []
    original = scenario.ScenarioDriver.__init__

    def spy(self: scenario.ScenarioDriver, *args: Any, **kwargs: Any) -> None:
        original(self, *args, **kwargs)
        drivers.append(self)

    monkeypatch.setattr(scenario.ScenarioDriver, "__init__", spy)
    script, transcript = tmp_path / "s.yaml", tmp_path / "t.jsonl"
    script.write_text(SCRIPT, encoding="utf-8")

    result = CliRunner().invoke(
        cli, ["sim", "--script", str(script), "--speed", "max", "--transcript", str(transcript)]
    )

    assert result.exit_code == 0, result.output
    records = [json.loads(line) for line in transcript.read_text(encoding="utf-8").splitlines()]
    assert f"wrote {len(records)} records" in result.output
    assert {
        "t": 35.0,
        "t_ns": 35_000_000_000,
        "type": "heard",
        "text": "hello",
    } in records  # 'when' still waits
    assert "[    35.0s] User: hello" in result.output
    [driver] = drivers
    assert driver.count == len(records) and driver.records == [], "the run kept its records in memory"


def test_a_second_sim_on_the_same_data_folder_is_refused_naming_the_first(tmp_path: Path) -> None:
    data = tmp_path / "data"
    script = tmp_path / "long.yaml"
    script.write_text("until: 3600\n", encoding="utf-8")
    cyborg = str(CYBORG_SCRIPT)
    first = subprocess.Popen(
        [cyborg, "sim", "--script", str(script), "--speed", "1", "--data-dir", str(data)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        lock = data / "sim.lock"
        give_up = time.monotonic() + 120  # a guard, not a speed check: it holds the folder within seconds
        while (
            first.poll() is None and time.monotonic() < give_up and f"process {first.pid}" not in held(lock)
        ):
            time.sleep(0.1)
        assert first.poll() is None, first.stderr.read() if first.stderr else ""
        assert f"cyborg sim --script (process {first.pid})" in held(lock), (
            "the first sim does not hold the folder"
        )

        second = CliRunner().invoke(
            cli, ["sim", "--script", str(script), "--speed", "max", "--data-dir", str(data)]
        )

        assert second.exit_code == 1, second.output
        assert (
            f"in use by cyborg sim --script (process {first.pid}); fix: stop that one first" in second.output
        )
    finally:
        first.terminate()
        first.wait()
    after = CliRunner().invoke(
        cli, ["sim", "--script", str(script), "--speed", "max", "--data-dir", str(data)]
    )
    assert after.exit_code == 0, after.output  # the lock went with the first process


def held(lock: Path) -> str:
    return lock.read_text(encoding="utf-8") if lock.exists() else ""


def test_a_full_disk_at_start_is_one_line_naming_the_fix(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import cyborg.modules.music as music

    def full(path: Path, **_: Any) -> float:
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(music, "synthesise", full)
    script = tmp_path / "s.yaml"
    script.write_text("until: 5\n", encoding="utf-8")

    result = CliRunner().invoke(
        cli, ["sim", "--script", str(script), "--speed", "max", "--data-dir", str(tmp_path / "d")]
    )

    assert result.exit_code == 1, result.output
    assert isinstance(result.exception, SystemExit), result.exception
    assert "cyborg-tune.wav: No space left on device; fix: free some space on that disk" in result.output
