#!/usr/bin/env python3
"""A behaviour module built against the NTNU Cyborg's published cyborg_controller package.

Plain rospy and actionlib, nothing of the cyborg package. Its messages are that package's
(scripts/install-ros --flavour public): the StateMachine goal has a fourth field, order, and
the EmotionalStateService request is a string, nothing. Their MD5 sums differ from the
thesis's, so it connects only to a controller running with the same definitions. Run it with
Debian's /usr/bin/python3 and those messages on PYTHONPATH, as
tests/ros/test_public_package.py does.

On a goal: ask the emotional-state service (with the `nothing` request), send feedback, and
succeed with the result message "order=<goal.order> emotion=<the answer's emotional_state>".
Prints "public package module ready" on stderr once its server is started.
"""

import sys
from typing import Any

import actionlib
import rospy
from cyborg_controller.msg import (
    StateMachineAction,
    StateMachineFeedback,
    StateMachineGoal,
    StateMachineResult,
)
from cyborg_controller.srv import EmotionalStateService, EmotionalStateServiceRequest

EMOTION_SERVICE = "cyborg_controller/get_emotional_state"


class PublicPackageModule:
    def __init__(self) -> None:
        if "order" not in StateMachineGoal.__slots__:
            sys.exit("these are not the public package's messages: StateMachineGoal has no 'order'")
        self.emotion = rospy.ServiceProxy(EMOTION_SERVICE, EmotionalStateService)
        self.server = actionlib.SimpleActionServer(
            rospy.get_name() + "/run", StateMachineAction, execute_cb=self.execute, auto_start=False
        )
        self.server.start()

    def execute(self, goal: Any) -> None:
        rospy.loginfo("goal: order=%s event=%s state=%s", goal.order, goal.event, goal.current_state)
        rospy.wait_for_service(EMOTION_SERVICE, timeout=5.0)
        answer = self.emotion(EmotionalStateServiceRequest(nothing=""))
        self.server.publish_feedback(StateMachineFeedback(status="running", message=goal.event))
        self.server.set_succeeded(
            StateMachineResult(status="done", message=f"order={goal.order} emotion={answer.emotional_state}")
        )


if __name__ == "__main__":
    rospy.init_node("cyborg_public_module")
    module = PublicPackageModule()
    print("public package module ready", file=sys.stderr, flush=True)
    rospy.spin()
