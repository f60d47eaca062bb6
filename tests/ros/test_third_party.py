"""Our controller drives a module written with plain rospy + actionlib, as the thesis's modules are.

The module (third_party_module.py) runs under Debian's /usr/bin/python3 with only the
environment of .venv/ros/setup.sh: it imports nothing of ours but the generated
cyborg_controller messages, so this checks the wire: action names and types, goal fields,
preemption, results and events, between our `cyborg node cyborg_controller` and it.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from actionlib_msgs.msg import GoalStatus  # type: ignore[import-not-found]
from cyborg_controller.msg import (  # type: ignore[import-not-found]
    StateMachineActionFeedback,
    StateMachineActionResult,
)

from tests.support.ros import Observers, Processes

HERE = Path(__file__).resolve().parent
MACHINE = HERE / "third_party.yaml"
MODULE = HERE / "third_party_module.py"
PREEMPT_TIMEOUT = 2.0  # third_party.yaml's timeouts.preempt
SYSTEM_PYTHON = "/usr/bin/python3"  # Debian's, which the ROS packages are built for


def test_controller_drives_a_plain_rospy_module(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    assert os.access(SYSTEM_PYTHON, os.X_OK), f"{SYSTEM_PYTHON} is needed (Debian's ROS runs on it)"
    changes = observe.state_changes()
    feedback = observe.topic("/cyborg_third_party/run/feedback", StateMachineActionFeedback)
    results = observe.topic("/cyborg_third_party/run/result", StateMachineActionResult)
    module = processes.start("cyborg_third_party", [SYSTEM_PYTHON, str(MODULE)], "third party module ready")
    idle = processes.cyborg_node("cyborg_test_idle", MACHINE, tmp_path)
    processes.wait_ready(module, idle)
    controller = processes.cyborg_node("cyborg_controller", MACHINE, tmp_path)
    processes.wait_ready(controller)
    feedback.wait_connected()
    results.wait_connected()
    events = observe.events()
    changes.wait_state("idle", event="start")
    events.wait_connected()

    # The controller enters the module's state; the module runs; an event preempts it.
    mark = changes.mark()
    events.send("visit")
    changes.wait_state("third_party", event="visit", after=mark)
    running = feedback.wait_for(lambda h: h.message.feedback.message == "visit", what="feedback of the visit")
    assert running.sender == "cyborg_third_party"
    assert running.message.feedback.status == "running"
    sent = events.send("leave")
    left = changes.wait_state("idle", event="leave", after=mark)
    assert left.at - sent < PREEMPT_TIMEOUT, (
        "the controller waited for the preempt timeout: no acknowledgement"
    )
    result = results.wait_for(lambda h: h.message.result.message == "left visit", what="the visit's result")
    assert result.message.status.status == GoalStatus.PREEMPTED
    assert result.message.result.status == "preempted"

    # The module registers an event itself; the controller acts on it (preempting the module).
    mark = changes.mark()
    entered = time.monotonic()
    events.send("visit_briefly")
    changes.wait_state("third_party", event="visit_briefly", after=mark)
    onwards = changes.wait_state("farewell", event="third_party_finished", after=mark)
    assert onwards.at - entered < 1.5, "the module did not acknowledge, or its event came late"
    result = results.wait_for(lambda h: h.message.result.message == "left visit_briefly", what="its result")
    assert result.message.status.status == GoalStatus.PREEMPTED
    assert changes.path(mark) == [
        ("idle", "visit_briefly", "third_party"),
        ("third_party", "third_party_finished", "farewell"),
    ]
    assert module.process.poll() is None and controller.process.poll() is None
