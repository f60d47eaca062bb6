"""A client written in plain rclpy (foreign_client.py, its own process, nothing of ours) uses
the robot over ROS 2 as ROS 1 tools do: it reads state_change, calls get_emotional_state and
publishes register_event, which makes our controller (built in this process) change state."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from test_ros2_foreign_module import PATIENCE, Process, support

from cyborg.app.config import load_config
from cyborg.app.robot import build_robot
from cyborg.testing.wait import wait_until
from cyborg.transport import topics
from cyborg.transport.messages import SystemState

HERE = Path(__file__).resolve().parent
FAULTS = HERE.parent / "ros" / "faults.yaml"  # idle and working, both served in this process


def test_plain_rclpy_client_reads_state_asks_emotion_and_sends_an_event(
    request: pytest.FixtureRequest, tmp_path: Path
) -> None:
    session = support().ros2_session(request.config)
    transport, clock = session.transport, session.clock
    robot = build_robot(load_config(FAULTS), transport, data_dir=tmp_path)
    observer = transport.node("cyborg_test_client_observer")
    changes: list[SystemState] = []
    observer.subscribe(topics.STATE_CHANGE, SystemState, lambda m, i: changes.append(m))
    client: Process | None = None
    expected: list[str] = []

    async def main() -> None:
        nonlocal client
        robot.start()
        assert await wait_until(
            lambda: any(c.to_system_state == "idle" for c in changes), clock, timeout=PATIENCE
        )
        client = Process([sys.executable, str(HERE / "foreign_client.py"), "work"])
        assert await wait_until(lambda: client.process.poll() is not None, clock, timeout=PATIENCE + 10)
        # The client saw the change and left; this process's observer hears it on its own loop turn.
        await wait_until(lambda: bool(changes) and changes[-1].event == "work", clock, timeout=PATIENCE)
        p, a, d = robot.emotion.pad.as_tuple()  # neutral, unchanged since the client asked
        expected.append(f"emotion {robot.emotion.emotion} {p:.3f} {a:.3f} {d:.3f}")

    try:
        clock.run(main())
    finally:
        if client is not None:
            client.stop()
        observer.shutdown()
        robot.close()
    assert client is not None
    assert client.process.returncode == 0, client.lines
    assert client.lines[0] == "state_change  -start-> idle", client.lines  # the latched last change
    assert client.lines[1] == expected[0], client.lines
    assert client.lines[2] == "state_change idle -work-> working", client.lines
    assert changes[-1] == SystemState("work", "idle", "working")
