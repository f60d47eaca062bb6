"""A behaviour module written in plain rclpy: nothing of the cyborg package (docs/ros2.md).

Node /cyborg_foreign with three ActionServers of cyborg_controller/action/StateMachine:
``talk`` and ``muted`` say "<state> line <n>" on /text_to_speech every 0.1 s while their goal
runs and end it canceled when the controller cancels; ``stubborn`` talks the same way and
accepts the cancel but never ends its goal. Each goal's start and end is printed on stdout.
"""

import contextlib
import sys
import time

import rclpy
from cyborg_controller.action import StateMachine
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import String


class ForeignModule(Node):
    def __init__(self):
        super().__init__("cyborg_foreign")
        group = ReentrantCallbackGroup()  # a cancel is heard while a goal executes
        self.speech = self.create_publisher(String, "/text_to_speech", 10)
        self.servers = [
            ActionServer(
                self,
                StateMachine,
                f"/cyborg_foreign/{name}",
                execute_callback=self.stubborn if name == "stubborn" else self.talk,
                goal_callback=lambda goal: GoalResponse.ACCEPT,
                cancel_callback=lambda handle: CancelResponse.ACCEPT,
                callback_group=group,
            )
            for name in ("talk", "muted", "stubborn")
        ]

    def say_until(self, handle, stop):
        state = handle.request.current_state
        print(f"goal {state} active", flush=True)
        n = 0
        while not stop():
            self.speech.publish(String(data=f"{state} line {n}"))
            n += 1
            time.sleep(0.1)
        return state

    def talk(self, handle):
        state = self.say_until(handle, lambda: handle.is_cancel_requested)
        handle.canceled()
        print(f"goal {state} canceled", flush=True)
        return StateMachine.Result()

    def stubborn(self, handle):
        self.say_until(handle, lambda: False)  # never ends: the controller's preempt timeout does
        return StateMachine.Result()


def main():
    rclpy.init()
    module = ForeignModule()
    executor = MultiThreadedExecutor(num_threads=8)
    executor.add_node(module)
    ours = sorted(name for name in sys.modules if name == "cyborg" or name.startswith("cyborg."))
    print(f"foreign module ready; cyborg modules imported: {ours}", flush=True)
    with contextlib.suppress(KeyboardInterrupt, ExternalShutdownException):
        executor.spin()


if __name__ == "__main__":
    main()
