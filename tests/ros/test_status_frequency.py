"""An idle robot's action servers report their status once a second, not at actionlib's 5 Hz.

Ten idle modules sent the controller 50 status messages a second. Our servers now send one a
second (and one at every change of a goal); actionlib's own parameter ``actionlib_status_frequency``
still sets the rate when it is on the master, as for any actionlib server.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from cyborg.transport.base import ServerGoalHandle
from cyborg.transport.messages import StateMachineAction
from cyborg.transport.ros.actions import STATUS_FREQUENCY
from tests.support.ros import RosSession

LISTEN = 2.0  # seconds of status messages counted


def _status_messages(ros: RosSession, node_name: str, action: str) -> int:
    """Status messages a new server of ``action`` sends in LISTEN seconds, heard by a bare rospy subscriber."""
    import rospy  # type: ignore[import-not-found]
    from actionlib_msgs.msg import GoalStatusArray  # type: ignore[import-not-found]

    def nothing(handle: ServerGoalHandle[Any, Any, Any]) -> None:
        return None

    node = ros.transport.node(node_name)
    heard: list[float] = []
    lock = threading.Lock()

    def on_status(message: object) -> None:
        with lock:
            heard.append(time.monotonic())

    subscriber = rospy.Subscriber(f"{action}/status", GoalStatusArray, on_status)
    try:
        node.action_server(action, StateMachineAction, nothing, nothing)
        deadline = time.monotonic() + 10.0
        while not heard and time.monotonic() < deadline:  # the latched first one: connected
            time.sleep(0.02)
        assert heard, f"no status from {action} within 10 s"
        start = heard[0]
        time.sleep(LISTEN)
        with lock:
            return sum(1 for at in heard if start < at <= start + LISTEN)
    finally:
        subscriber.unregister()
        node.shutdown()


def test_our_servers_report_once_a_second_and_actionlibs_parameter_still_sets_the_rate(
    ros: RosSession,
) -> None:
    import rospy

    quiet = _status_messages(ros, "status_rate_default", "/cyborg_test/status_rate/default")
    assert quiet <= STATUS_FREQUENCY * LISTEN + 1, f"{quiet} status messages in {LISTEN} s"

    rospy.set_param("/actionlib_status_frequency", 10.0)
    try:
        set_rate = _status_messages(ros, "status_rate_param", "/cyborg_test/status_rate/param")
    finally:
        rospy.delete_param("/actionlib_status_frequency")
    assert set_rate >= 10.0 * LISTEN / 2, f"{set_rate} status messages in {LISTEN} s at 10 Hz"
