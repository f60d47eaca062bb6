"""A plain rospy node for tests/ros/test_recovery.py: sends events, prints the state changes it hears.

``python ros_probe.py NODE_NAME`` on ``ROS_MASTER_URI``. It prints ``ready`` once its event
publisher is connected to the controller and it has heard the controller's latched state (both
connections made through the master), then one line per state change
(``state FROM EVENT TO``, ``-`` for an empty FROM); each stdin line ``send EVENT`` publishes EVENT
on /cyborg_controller/register_event. It ends when stdin closes.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any

import rospy  # type: ignore[import-not-found]
from cyborg_controller.msg import SystemState  # type: ignore[import-not-found]
from std_msgs.msg import String  # type: ignore[import-not-found]


def main(name: str) -> None:
    rospy.init_node(name, disable_signals=True)
    lock = threading.Lock()
    heard = threading.Event()

    def say(line: str) -> None:
        with lock:
            print(line, flush=True)

    def on_state(message: Any) -> None:
        say(f"state {message.from_system_state or '-'} {message.event} {message.to_system_state}")
        heard.set()

    rospy.Subscriber("/cyborg_controller/state_change", SystemState, on_state)
    events = rospy.Publisher("/cyborg_controller/register_event", String, queue_size=10)
    while events.get_num_connections() < 1 or not heard.is_set():  # the test bounds the wait
        time.sleep(0.01)
    say("ready")
    for line in sys.stdin:
        command, _, argument = line.strip().partition(" ")
        if command == "send":
            events.publish(String(data=argument))
    rospy.signal_shutdown("stdin closed")


if __name__ == "__main__":
    main(sys.argv[1])
