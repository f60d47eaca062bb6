"""The plain-rospy variant that `cyborg new module` writes works beside our ROS nodes.

Run as a student would (no catkin): the project's venv python runs `rospy_node.py`; our
controller drives it, and its reply passes the speech gatekeeper to the text-to-speech.
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

import rospy  # type: ignore[import-not-found]
from click.testing import CliRunner
from std_msgs.msg import String  # type: ignore[import-not-found]

from cyborg.cli import cli
from tests.support.ros import Observers, Processes


def test_the_rospy_variant_is_driven_by_our_controller_and_is_heard(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    assert CliRunner().invoke(cli, ["new", "module", "greeter", "--dir", str(tmp_path)]).exit_code == 0
    folder = tmp_path / "greeter"
    config = folder / "robot.yaml"  # its `greeter` module entry is not started: the rospy node serves instead
    changes = observe.state_changes()
    spoken = observe.topic("/cyborg_tts/spoken", String)
    nodes = [
        processes.cyborg_node(name, config, tmp_path / "db")
        for name in ("cyborg_idle", "cyborg_tts", "cyborg_speech_gatekeeper", "cyborg_controller")
    ]
    rospy_node = processes.start(
        "greeter", [sys.executable, str(folder / "src" / "greeter" / "rospy_node.py")], "greeter ready"
    )
    processes.wait_ready(*nodes, rospy_node)
    changes.wait_state("idle", event="start")

    speech = rospy.Publisher("/text_from_speech", String, queue_size=10)
    deadline = time.monotonic() + 10
    while speech.get_num_connections() < 1 and time.monotonic() < deadline:
        time.sleep(0.02)
    mark = changes.mark()
    speech.publish(String(data="Hello greeter, nice to meet you"))
    changes.wait_state("greeter", event="greeter_wanted", after=mark, timeout=10)
    spoken.wait_for(
        lambda h: h.message.data == "Hello! I am the greeter module.", timeout=10, what="the reply"
    )
    changes.wait_state("idle", event="succeeded", after=mark, timeout=10)
    speech.unregister()


def test_the_rospy_variant_waits_its_seconds_in_simulated_time_with_a_coarse_clock(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    """Under /use_sim_time (`cyborg launch --speed 20`: /clock in steps of 2 s) the node stays in
    control for its 3 s of simulated time at least. A goal that comes between two steps came
    after the clock's last reading, so counting from that reading would end it too early."""
    import actionlib  # type: ignore[import-not-found]
    from actionlib_msgs.msg import GoalStatus  # type: ignore[import-not-found]
    from cyborg_controller.msg import StateMachineAction, StateMachineGoal  # type: ignore[import-not-found]
    from rosgraph_msgs.msg import Clock  # type: ignore[import-not-found]

    assert CliRunner().invoke(cli, ["new", "module", "greeter", "--dir", str(tmp_path)]).exit_code == 0
    now = [100.0]
    ticking = threading.Event()
    clock = rospy.Publisher("/clock", Clock, queue_size=10)

    def tick() -> None:  # the same reading again and again, until the test moves it on
        while not ticking.is_set():
            clock.publish(Clock(clock=rospy.Time.from_sec(now[0])))
            time.sleep(0.05)

    ticker = threading.Thread(target=tick, daemon=True)
    rospy.set_param("/use_sim_time", True)
    try:
        ticker.start()
        script = tmp_path / "greeter" / "src" / "greeter" / "rospy_node.py"
        node = processes.start("greeter", [sys.executable, str(script)], "greeter ready")
        processes.wait_ready(node)
        client = actionlib.SimpleActionClient("/greeter/run", StateMachineAction)
        assert client.wait_for_server(rospy.Duration(20)), node.log()
        client.send_goal(StateMachineGoal(current_state="greeter"))
        deadline = time.monotonic() + 10
        while client.get_state() != GoalStatus.ACTIVE:
            assert time.monotonic() < deadline, f"the goal never became active: {node.log()}"
            time.sleep(0.02)
        time.sleep(0.3)  # the goal came after the reading 100, before the next: somewhere in [100, 102)
        for step in (102.0, 104.0):
            now[0] = step
            time.sleep(0.6)
        # at 104 the goal may have had only 2+ s: it must still run
        assert client.get_state() == GoalStatus.ACTIVE, f"ended after less than 3 simulated s: {node.log()}"
        now[0] = 106.0
        assert client.wait_for_result(rospy.Duration(10)), node.log()
        assert client.get_state() == GoalStatus.SUCCEEDED
    finally:
        ticking.set()
        ticker.join(timeout=5)
        rospy.delete_param("/use_sim_time")
        clock.unregister()
