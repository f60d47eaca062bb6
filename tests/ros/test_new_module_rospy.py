"""The plain-rospy variant that `cyborg new module` writes works beside our ROS nodes.

Run as a student would (no catkin): the project's venv python runs `rospy_node.py`; our
controller drives it, and its reply passes the speech gatekeeper to the text-to-speech.
"""

from __future__ import annotations

import sys
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
