"""The ROS 2 transport's executor (HandOffExecutor) hands ready work to its threads without spinning.

rclpy's multi-threaded executor spun while a message waited for one of its threads: the waiting
message kept a condition of its wait set triggered, so every wait returned at once, and the
spinning thread held the GIL the other threads needed (in the handover benchmark, events and
action results reached the controller up to hundreds of ms late). Here the executor's only
thread is held by a callback while a second message waits: the process stays idle, and the
message is delivered once the thread is free.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest
import rclpy
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.context import Context
from rclpy.node import Node
from std_msgs.msg import String

from cyborg.transport.ros2.executor import HandOffExecutor
from tests.support.ros2 import isolate

WINDOW = 0.5  # seconds the second message waits for the executor's thread


@pytest.fixture
def context() -> Iterator[Context]:
    isolate()
    context = Context()
    rclpy.init(context=context)
    try:
        yield context
    finally:
        context.try_shutdown()


def test_a_message_waiting_for_a_busy_thread_does_not_make_the_executor_spin(context: Context) -> None:
    executor = HandOffExecutor(1, context=context)
    node = Node("cyborg_test_hand_off", context=context, start_parameter_services=False)
    executor.add_node(node)
    release = threading.Event()
    holding = threading.Event()
    received: list[str] = []

    def on_message(message: String) -> None:
        received.append(message.data)
        if message.data == "first":
            holding.set()
            release.wait(10)

    # Reentrant: the second message is handed to the pool while the first callback still runs.
    node.create_subscription(
        String, "/cyborg_test/hand_off", on_message, 10, callback_group=ReentrantCallbackGroup()
    )
    publisher = node.create_publisher(String, "/cyborg_test/hand_off", 10)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        deadline = time.monotonic() + 10
        while publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        publisher.publish(String(data="first"))
        assert holding.wait(10), "the first message never reached its callback"
        publisher.publish(String(data="second"))
        time.sleep(0.1)  # the second message arrives and is handed to the busy pool
        cpu = time.process_time()
        time.sleep(WINDOW)
        used = time.process_time() - cpu
        assert used < 0.3 * WINDOW, f"the process used {used:.2f} s of CPU in {WINDOW} s while it waited"
        assert received == ["first"]
        release.set()
        deadline = time.monotonic() + 10
        while len(received) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert received == ["first", "second"]
    finally:
        release.set()
        executor.shutdown(timeout_sec=2)
        spinner.join(timeout=5)
        node.destroy_node()
    assert not spinner.is_alive(), "the executor did not stop spinning at shutdown"
