"""A module process killed mid-goal, over ROS 2: the controller takes 'aborted' within 2 s.

As tests/ros/test_faults.py does on ROS 1, with tests/ros/faults.yaml: the worker module runs
in a process of its own (``build_part``, tests/ros2/part_process.py) and is killed with SIGKILL
while its goal is active; the controller and the idle module run in this process. A killed
process says goodbye to nobody: the others drop it when its participant's lease runs out
(1 s in our processes, docs/ros2.md), and its goal ends LOST, which the controller takes as
'aborted'.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from action_msgs.msg import GoalStatus, GoalStatusArray
from rclpy.action.server import qos_profile_action_status_default
from test_ros2_foreign_module import PATIENCE, Process, support

from cyborg.app.config import load_config
from cyborg.app.context import BuildContext
from cyborg.app.parts import build_part
from cyborg.testing.wait import wait_until
from cyborg.transport import topics
from cyborg.transport.messages import String, SystemState

HERE = Path(__file__).resolve().parent
FAULTS = HERE.parent / "ros" / "faults.yaml"  # the same machine as the ROS 1 test


@pytest.fixture
def worker(tmp_path: Path) -> Iterator[Process]:
    support().isolate()
    process = Process(
        [sys.executable, str(HERE / "part_process.py"), str(FAULTS), "cyborg_test_worker", str(tmp_path)]
    )
    try:
        yield process
    finally:
        process.stop()


def test_module_killed_mid_goal_makes_the_controller_take_aborted_within_2_s(
    worker: Process, request: pytest.FixtureRequest, tmp_path: Path
) -> None:
    session = support().ros2_session(request.config)
    transport, clock = session.transport, session.clock
    config = load_config(FAULTS)
    context = BuildContext(data_dir=tmp_path / "here", resume=False)
    idle = build_part("cyborg_test_idle", config, transport, context)
    controller = build_part("cyborg_controller", config, transport, context)
    observer = transport.node("cyborg_test_fault_observer")
    changes: list[tuple[float, SystemState, str]] = []
    observer.subscribe(
        topics.STATE_CHANGE, SystemState, lambda m, i: changes.append((time.monotonic(), m, i.sender))
    )
    events = observer.publisher(topics.REGISTER_EVENT, String)
    active: list[float] = []

    def on_status(message: GoalStatusArray) -> None:  # an executor thread
        if any(s.status == GoalStatus.STATUS_EXECUTING for s in message.status_list):
            active.append(time.monotonic())

    status = observer.rcl.create_subscription(  # type: ignore[attr-defined]
        GoalStatusArray,
        "/cyborg_test_worker/work/_action/status",
        on_status,
        qos_profile_action_status_default,
    )

    def path_since(mark: int) -> list[tuple[str, str, str]]:
        return [(m.from_system_state, m.event, m.to_system_state) for _, m, _ in changes[mark:]]

    async def main() -> None:
        worker.wait_line("part ready")
        assert controller.controller is not None
        controller.controller.start()
        assert await wait_until(lambda: ("", "start", "idle") in path_since(0), clock, timeout=PATIENCE)
        assert await wait_until(lambda: events.subscriber_count() > 0, clock, timeout=PATIENCE)
        mark = len(changes)
        events.publish(String("work"))
        assert await wait_until(
            lambda: ("idle", "work", "working") in path_since(mark), clock, timeout=PATIENCE
        )
        assert await wait_until(lambda: bool(active), clock, timeout=PATIENCE), "the worker's goal never ran"

        mark = len(changes)
        worker.process.kill()
        killed = time.monotonic()
        assert await wait_until(lambda: len(changes) > mark, clock, timeout=10.0), (
            "the controller never noticed"
        )
        at, change, sender = changes[mark]
        assert (change.from_system_state, change.event, change.to_system_state) == (
            "working",
            "aborted",
            "recovering",
        )
        assert sender == "cyborg_controller"
        assert at - killed < 2.0, f"the controller took {at - killed:.2f} s to notice"

    try:
        clock.run(main())
    finally:
        observer.rcl.destroy_subscription(status)  # type: ignore[attr-defined]
        for part in (controller, idle):
            part.close()
        observer.shutdown()
        clock.run(clock.sleep(0.05))  # the closed parts' goal tasks end on the loop
