#!/usr/bin/env python3
"""A third-party behaviour module, written as the thesis shows (chapters 2.1, 8.1.2 and 9.2).

Plain rospy and actionlib, nothing of the cyborg package: a SimpleActionServer of
cyborg_controller/StateMachineAction under the node's name, which runs until the
controller preempts it, and events on cyborg_controller/register_event. Run it with
Debian's /usr/bin/python3 and the environment of .venv/ros/setup.sh (which puts the
generated cyborg_controller messages on PYTHONPATH), as tests/ros/test_third_party.py does.

Behaviour, chosen by the goal's event:
  * any event: send feedback ("running", event), then run until preempted;
  * "visit_briefly": also register the event "third_party_finished" after 0.3 s.
Prints "third party module ready" on stderr once its server is started.
"""

import sys
from typing import Any

import actionlib
import rospy
from cyborg_controller.msg import StateMachineAction, StateMachineFeedback, StateMachineResult
from std_msgs.msg import String


class ThirdPartyModule:
    def __init__(self) -> None:
        self.event_publisher = rospy.Publisher("cyborg_controller/register_event", String, queue_size=100)
        self.server = actionlib.SimpleActionServer(
            rospy.get_name() + "/run", StateMachineAction, execute_cb=self.execute, auto_start=False
        )
        self.server.start()

    def execute(self, goal: Any) -> None:
        event = goal.event
        rospy.loginfo("entered state %s on event %s", goal.current_state, event)
        self.server.publish_feedback(StateMachineFeedback(status="running", message=event))
        started = rospy.get_time()
        finished_sent = False
        rate = rospy.Rate(50)
        while not rospy.is_shutdown():
            if self.server.is_preempt_requested():
                # Do things needed to be done, before leaving state
                self.server.set_preempted(StateMachineResult(status="preempted", message="left " + event))
                return
            if event == "visit_briefly" and not finished_sent and rospy.get_time() - started > 0.3:
                self.event_publisher.publish("third_party_finished")
                finished_sent = True
            rate.sleep()


if __name__ == "__main__":
    rospy.init_node("cyborg_third_party")
    module = ThirdPartyModule()
    print("third party module ready", file=sys.stderr, flush=True)
    rospy.spin()
