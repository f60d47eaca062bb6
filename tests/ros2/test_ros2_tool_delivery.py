"""The command tool over ROS 2 reaches every listener, every time (issue: `cyborg say --ros2` lost
messages to discovery): each call is a fresh node, as each `cyborg say --ros2` is a fresh process,
and a plain rclpy subscriber with volatile QoS (a student's logger, `ros2 topic echo`) listens
beside one of ours. Runs in .venv-ros2 (tests/ros2/conftest.py)."""

from __future__ import annotations

import asyncio
import os
import threading
from collections.abc import Iterator

import pytest

from cyborg.client.ros import RosLink
from cyborg.run.middleware import ROS2
from cyborg.transport import topics
from cyborg.transport.messages import String
from tests.support.ros2 import Ros2Session

SENDS = 50


@pytest.fixture
def own_session(monkeypatch: pytest.MonkeyPatch) -> Iterator[Ros2Session]:
    # A domain of the test's own (the runner picks 1-100; test_ros2_robot takes +100; DDS has 0-232).
    monkeypatch.setenv("ROS_DOMAIN_ID", str(int(os.environ.get("ROS_DOMAIN_ID", "0")) + 120))
    session = Ros2Session()
    yield session
    session.close()


@pytest.fixture
def plain_listener(own_session: Ros2Session) -> Iterator[list[str]]:
    """A plain rclpy node with a volatile subscription, spun on a thread of its own."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import String as RosString

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("plain_logger", context=context)
    heard: list[str] = []
    node.create_subscription(RosString, topics.TEXT_FROM_SPEECH, lambda m: heard.append(m.data), 10)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    yield heard
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown(context=context)


def test_every_say_reaches_every_listener(own_session: Ros2Session, plain_listener: list[str]) -> None:
    session = own_session
    ours: list[str] = []
    node = session.transport.node("speech_module")
    node.subscribe(topics.TEXT_FROM_SPEECH, String, lambda m, i: ours.append(m.data))
    reached: list[list[str] | None] = []

    def send_all() -> None:
        for n in range(SENDS):
            link = RosLink(ROS2)
            try:
                link.say(f"what time is it {n}")
                reached.append(link.delivered_to)
            finally:
                link.close()

    async def run() -> None:  # our subscription's callbacks run on the session's loop meanwhile
        await asyncio.to_thread(send_all)
        for _ in range(100):
            if len(ours) == SENDS and len(plain_listener) == SENDS:
                return
            await asyncio.sleep(0.05)

    session.clock.run(run())
    expected = [f"what time is it {n}" for n in range(SENDS)]
    assert ours == expected
    assert plain_listener == expected
    assert all(names is not None and {"speech_module", "plain_logger"} <= set(names) for names in reached), (
        reached
    )
