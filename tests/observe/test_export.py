"""``cyborg export``: a recording as a ROS 1 bag that Debian's own ``rosbag`` opens, and as a ROS 2
bag that ``rosbags`` reads back."""

from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from cyborg.cli import cli


@pytest.mark.ros
def test_a_ros1_export_opens_in_rosbag_info(d_run: tuple[Path, Path, str], tmp_path: Path) -> None:
    _, recording, _ = d_run
    bag = tmp_path / "d.bag"
    result = CliRunner().invoke(cli, ["export", str(recording), "--to", "rosbag", "-o", str(bag)])
    assert result.exit_code == 0, result.output
    info = subprocess.run(["rosbag", "info", str(bag)], capture_output=True, text=True, timeout=60)
    assert info.returncode == 0, info.stderr
    # The MD5 sums are those ROS computes from the package's .msg files (genmsg).
    assert "cyborg_controller/SystemState           [33e4fca93c330d18c8a8d3b755c771c5]" in info.stdout
    assert "cyborg_controller/EmotionalState        [ff5f086e373f1e982e89fbc9298d99be]" in info.stdout
    assert "/cyborg_controller/state_change" in info.stdout
    again = CliRunner().invoke(cli, ["export", str(recording), "--to", "rosbag", "-o", str(bag)])
    assert again.exit_code == 1 and "exists already; fix" in again.output


def test_a_ros2_export_reads_back_with_rosbags(d_run: tuple[Path, Path, str], tmp_path: Path) -> None:
    from rosbags.highlevel import AnyReader

    transcript, recording, _ = d_run
    out = tmp_path / "d_ros2"
    result = CliRunner().invoke(cli, ["export", str(recording), "--to", "rosbag2", "-o", str(out)])
    assert result.exit_code == 0, result.output
    import json

    expected = [
        (r["from"], r["event"], r["to"])
        for r in map(json.loads, transcript.read_text().splitlines())
        if r["type"] == "state"
    ]
    with AnyReader([out]) as reader:
        wanted = [c for c in reader.connections if c.topic == "/cyborg_controller/state_change"]
        states = []
        for connection, _, raw in reader.messages(connections=wanted):
            message: Any = reader.deserialize(raw, connection.msgtype)
            states.append((message.from_system_state, message.event, message.to_system_state))
    assert states == expected


def test_the_exported_message_definitions_are_the_ros_package_s(tmp_path: Path) -> None:
    from tests.support.paths import ROOT

    for name in ("SystemState", "EmotionalState"):
        packaged = ROOT / "src" / "cyborg" / "observe" / "msg" / f"{name}.msg"
        assert (
            packaged.read_text() == (ROOT / "ros" / "cyborg_controller" / "msg" / f"{name}.msg").read_text()
        )
