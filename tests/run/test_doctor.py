"""``cyborg doctor`` without a graph: this machine against the real robot's configuration.

Run as a user runs it (a process of its own: PortAudio reads the sound devices once per
process), with ALSA's null device as a working speaker and microphone, then with a sound card
that is not there. The graph checks run over ROS 1 and ROS 2 in tests/ros/test_real_robot.py
and tests/ros2/test_ros2_real_robot.py.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from tests.support.sound import alsa_home


def _doctor(tmp_path: Path, *extra: str, device: bool) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "XDG_CONFIG_HOME": str(alsa_home(tmp_path / f"sound-{device}", device=device))}
    command = [
        sys.executable,
        "-m",
        "cyborg.cli",
        "doctor",
        "--config",
        "robot",
        "--db",
        str(tmp_path / "data"),
    ]
    return subprocess.run([*command, *extra], capture_output=True, text=True, env=env, timeout=60)


def test_a_machine_with_speaker_and_microphone_passes_every_check(tmp_path: Path) -> None:
    done = _doctor(tmp_path, device=True)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    assert lines[-1].startswith("all checks passed (")
    assert [line.split(":")[0] for line in lines[:-1]] == [
        "ok   configuration",
        f"ok   data folder {tmp_path / 'data'}",
        "ok   speech output (cyborg_tts)",
        "ok   microphone (cyborg_speech)",
    ]


def test_without_a_sound_card_the_doctor_names_speaker_and_microphone_with_the_fix(tmp_path: Path) -> None:
    done = _doctor(tmp_path, "--json", device=False)
    assert done.returncode == 1, done.stdout + done.stderr
    report = json.loads(done.stdout)
    assert report["passed"] is False
    failed = {c["name"]: c for c in report["checks"] if c["status"] == "failed"}
    assert set(failed) == {"speech output (cyborg_tts)", "microphone (cyborg_speech)"}
    assert "plug in the speaker" in failed["speech output (cyborg_tts)"]["fix"]
    assert "arecord -l" in failed["microphone (cyborg_speech)"]["fix"]
    assert all(c["seconds"] < 10 for c in report["checks"])
