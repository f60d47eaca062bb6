"""The stock ROS tools in a shell where only `.venv/bin/activate` was sourced.

rosmsg, rostopic echo/pub, rosservice call, rosbag record/info and roslaunch (with a file
written by `cyborg launch --write`) against our nodes on the session's roscore.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from cyborg.emotion.model import PAD
from cyborg.motivator.store import ControllerStore
from tests.support.ros import Observers, Processes

FAULTS = Path(__file__).resolve().parent / "faults.yaml"
ACTIVATE = Path(sys.prefix) / "bin" / "activate"


def user_shell_environment() -> dict[str, str]:
    """A login-like environment: no ROS variables but the master's address, as a user would have."""
    keep = ("PATH", "HOME", "LANG", "TERM", "TMPDIR")
    env = {k: v for k, v in os.environ.items() if k in keep}
    if "ROS_MASTER_URI" in os.environ:  # the session's master (tests/ros/conftest.py)
        env["ROS_MASTER_URI"] = os.environ["ROS_MASTER_URI"]
    env["ROS_HOME"] = os.environ.get("ROS_HOME", "/tmp")
    return env


def in_activated_shell(command: str, **kwargs: object) -> subprocess.Popen[str]:
    return subprocess.Popen(  # type: ignore[call-overload, no-any-return]
        ["bash", "-c", f'. "{ACTIVATE}" && exec {command}'],
        env=user_shell_environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        **kwargs,
    )


def run(command: str, timeout: float = 30.0) -> str:
    process = in_activated_shell(command)
    out, _ = process.communicate(timeout=timeout)
    assert process.returncode == 0, f"{command} failed ({process.returncode}):\n{out}"
    return out


def test_rosmsg_knows_our_types() -> None:
    out = run("rosmsg show cyborg_controller/SystemState")
    assert out.split() == ["string", "event", "string", "from_system_state", "string", "to_system_state"]
    out = run("rossrv show cyborg_controller/EmotionalStateService")
    assert "string emotional_state" in out and "float32 current_pleasure" in out


def test_rostopic_rosservice_and_rosbag_on_a_running_controller(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    changes = observe.state_changes()
    nodes = [
        processes.cyborg_node(name, FAULTS, tmp_path) for name in ("cyborg_test_idle", "cyborg_test_worker")
    ]
    controller = processes.cyborg_node("cyborg_controller", FAULTS, tmp_path)
    processes.wait_ready(*nodes, controller)
    changes.wait_state("idle", event="start")

    out = run("rostopic echo -n 1 /cyborg_controller/state_change")  # latched: the current state
    assert 'to_system_state: "idle"' in out

    bag = tmp_path / "changes.bag"
    recorder = in_activated_shell(f"rosbag record -O {bag} /cyborg_controller/state_change")
    try:
        deadline = time.monotonic() + 20
        while not any(p.name.startswith("changes.bag") for p in tmp_path.iterdir()):
            assert time.monotonic() < deadline, "rosbag did not start recording"
            time.sleep(0.1)
        mark = changes.mark()
        run('rostopic pub -1 /cyborg_controller/register_event std_msgs/String "data: work"')
        changes.wait_state("working", event="work", after=mark)
        time.sleep(0.5)
    finally:
        recorder.send_signal(signal.SIGINT)
        recorder.communicate(timeout=20)
    info = run(f"rosbag info {bag}")
    assert "cyborg_controller/SystemState" in info
    recorded = int(info.split("messages:")[1].split()[0])
    assert recorded >= 1, info

    out = run("rosservice call /cyborg_controller/get_emotional_state")
    assert 'emotional_state: "neutral"' in out and "current_pleasure: 0.0" in out


def test_roslaunch_starts_the_robot_from_a_written_launch_file(observe: Observers, tmp_path: Path) -> None:
    launch_file = tmp_path / "robot.launch"
    run(f"cyborg launch --config {FAULTS} --db {tmp_path} --write {launch_file}")
    store = ControllerStore(tmp_path / "controller.db")  # a robot stopped a moment ago, angry and off
    store.save_emotion(PAD(-0.51, 0.59, 0.25), time.time())
    store.set_emotion_enabled(False)
    store.close()
    changes = observe.state_changes()
    roslaunch = in_activated_shell(f"roslaunch {launch_file}", start_new_session=True)
    try:
        change = changes.wait_state("idle", event="start", timeout=60)
        assert change.sender == "cyborg_controller"  # the node keeps its part's name under roslaunch
        out = run("rosservice call /cyborg_controller/get_emotional_state")
        assert 'emotional_state: "neutral"' in out, "a launch is a fresh start (thesis 8.2)"
        assert run("rosparam get /cyborg_controller/emotion_enabled").strip() == "true"
        mark = changes.mark()
        run('rostopic pub -1 /cyborg_controller/register_event std_msgs/String "data: work"')
        changes.wait_state("working", event="work", after=mark)
    finally:
        os.killpg(roslaunch.pid, signal.SIGINT)
        out, _ = roslaunch.communicate(timeout=30)
    assert "cyborg_test_worker (cyborg_controller/cyborg)" in out
