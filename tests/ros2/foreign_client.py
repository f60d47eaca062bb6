"""A client of the Cyborg written in plain rclpy: nothing of the cyborg package (docs/ros2.md).

Usage: foreign_client.py EVENT. It reads the controller's state changes (a latched topic:
transient-local QoS), asks the emotion system for the emotional state, sends EVENT on
register_event and waits until the controller changes state on it. What it learns is printed
on stdout, one line each; it exits 0 when the state change on EVENT came, 1 after 20 s without.
"""

import os
import sys
import threading
import time

import rclpy
from cyborg_controller.msg import SystemState
from cyborg_controller.srv import EmotionalStateService
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

LATCHED = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)


def main():
    event = sys.argv[1]
    rclpy.init()
    node = Node("cyborg_foreign_client")
    changed = threading.Event()
    latched = threading.Event()

    def on_change(message):
        print(
            f"state_change {message.from_system_state} -{message.event}-> {message.to_system_state}",
            flush=True,
        )
        latched.set()
        if message.event == event:
            changed.set()

    node.create_subscription(SystemState, "/cyborg_controller/state_change", on_change, LATCHED)
    emotion = node.create_client(EmotionalStateService, "/cyborg_controller/get_emotional_state")
    events = node.create_publisher(String, "/cyborg_controller/register_event", 10)
    executor = MultiThreadedExecutor(num_threads=2)
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()

    deadline = time.monotonic() + 20
    # The latched change first, as a client that starts from the robot's state would: the
    # service can answer before the transient-local history arrives.
    latched.wait(max(0.0, deadline - time.monotonic()))
    if not emotion.wait_for_service(timeout_sec=20):
        sys.exit("no get_emotional_state service")
    answer = emotion.call(EmotionalStateService.Request(), timeout_sec=20)
    if answer is None:
        sys.exit("get_emotional_state did not answer")
    print(
        f"emotion {answer.emotional_state} {answer.current_pleasure:.3f} "
        f"{answer.current_arousal:.3f} {answer.current_dominance:.3f}",
        flush=True,
    )
    while events.get_subscription_count() < 1 and time.monotonic() < deadline:
        time.sleep(0.01)
    events.publish(String(data=event))
    ok = changed.wait(max(0.0, deadline - time.monotonic()))
    # Leave without the interpreter's teardown: rclpy's C++ objects, destroyed under the executor
    # thread, can abort the process (SIGABRT) at exit.
    sys.stdout.flush()
    os._exit(0 if ok else 1)


if __name__ == "__main__":
    main()
