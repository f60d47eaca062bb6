"""Our controller drives a module built against the NTNU Cyborg's published cyborg_controller package.

That package's StateMachine goal has a fourth field (``string order``, EXECUTE) and its
EmotionalStateService request is ``string nothing``, so its MD5 sums differ from the thesis's
and its modules cannot connect to a controller using the thesis's messages.
``scripts/install-ros --flavour public`` generates that package's definitions instead.

The session's venv keeps the thesis's messages (the other ROS tests need them): the public
flavour is installed into a throwaway venv, and the controller, a placeholder node and the
module (public_package_module.py, plain rospy under /usr/bin/python3) run with its generated
messages first on PYTHONPATH. This pytest process observes only topics whose types are the
same in both flavours (SystemState, EmotionalState, StateMachineActionResult, String).
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from actionlib_msgs.msg import GoalStatus  # type: ignore[import-not-found]
from cyborg_controller.msg import (  # type: ignore[import-not-found]
    EmotionalState,
    StateMachineActionResult,
    StateMachineGoal,
)

from tests.support.paths import ROOT
from tests.support.ros import Observers, Processes

HERE = Path(__file__).resolve().parent
MACHINE = HERE / "public_package.yaml"
MODULE = HERE / "public_package_module.py"
SYSTEM_PYTHON = "/usr/bin/python3"  # Debian's, which the ROS packages are built for

# MD5 sums of the published package's types (genmsg over its .action/.srv/.msg files); the
# thesis's differ for the goal types and the service (ros/NOTES.md), the rest are the same.
PUBLIC_MD5 = {
    "msg.StateMachineAction": "aba1823ad995835f5da8631bd349b082",
    "msg.StateMachineActionGoal": "d33cc3551fa471b293164f712da353ee",
    "msg.StateMachineGoal": "ca0cbc617848fd96cc506786c47de76e",
    "msg.StateMachineActionResult": "87fa4ab1749e50362cf20026157affb2",
    "msg.StateMachineActionFeedback": "3ae508299f4f746500589a2a4d60d41a",
    "msg.SystemState": "33e4fca93c330d18c8a8d3b755c771c5",
    "msg.EmotionalState": "ff5f086e373f1e982e89fbc9298d99be",
    "msg.EmotionalFeedback": "6f61bf537c02522f197246d02ded0f2c",
    "srv.EmotionalStateService": "68da7087fb08817fd317a07916f3d49f",
}
THESIS_GOAL_MD5 = "56826e083dcf8a7d74c0074ae54cc241"


def install_public_flavour(tmp_path: Path) -> Path:
    """``scripts/install-ros --venv VENV --flavour public`` into a new venv; its messages' directory."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    done = subprocess.run(
        [str(ROOT / "scripts" / "install-ros"), "--venv", str(venv), "--flavour", "public"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, f"install-ros --flavour public failed:\n{done.stdout}{done.stderr}"
    assert done.stdout.startswith("flavour public: generated the published cyborg_controller package's"), (
        done.stdout
    )
    assert "controller fills with EXECUTE" in done.stdout
    assert (venv / "ros" / "flavour").read_text().strip() == "public"
    again = subprocess.run(
        [str(ROOT / "scripts" / "install-ros"), "--venv", str(venv)], capture_output=True, text=True
    )
    assert (again.returncode, again.stdout) == (0, ""), "a later run without --flavour must keep the choice"
    assert (venv / "ros" / "flavour").read_text().strip() == "public"
    return venv / "ros"


def generated_md5(pythonpath: Path) -> dict[str, str]:
    """The MD5 sums of the cyborg_controller types importable from ``pythonpath`` (in Debian's python)."""
    script = (
        "import cyborg_controller.msg as msg, cyborg_controller.srv as srv\n"
        f"for key in {sorted(PUBLIC_MD5)!r}:\n"
        "    kind, name = key.split('.')\n"
        "    print(key, getattr({'msg': msg, 'srv': srv}[kind], name)._md5sum)\n"
    )
    out = subprocess.run(
        [SYSTEM_PYTHON, "-c", script],
        env={**os.environ, "PYTHONPATH": str(pythonpath)},
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return dict(line.split() for line in out.splitlines())


def test_controller_drives_a_module_built_against_the_public_package(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    import rospy  # type: ignore[import-not-found]
    from std_msgs.msg import String  # type: ignore[import-not-found]

    assert os.access(SYSTEM_PYTHON, os.X_OK), f"{SYSTEM_PYTHON} is needed (Debian's ROS runs on it)"
    ros_dir = install_public_flavour(tmp_path / "public")
    public_python = ros_dir / "lib" / "python"
    assert generated_md5(public_python) == PUBLIC_MD5
    # The session's own (default) install is still the thesis's.
    assert "order" not in StateMachineGoal.__slots__ and StateMachineGoal._md5sum == THESIS_GOAL_MD5

    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(public_python), os.environ.get("PYTHONPATH", "")]),
        "ROS_PACKAGE_PATH": os.pathsep.join([str(ros_dir / "share"), os.environ.get("ROS_PACKAGE_PATH", "")]),
    }
    changes = observe.state_changes()
    emotions = observe.topic("/cyborg_controller/emotional_state", EmotionalState)
    results = observe.topic("/cyborg_public_module/run/result", StateMachineActionResult)
    set_emotion = rospy.Publisher("/cyborg_controller/set_emotional_state", String, queue_size=10)
    try:
        module = processes.start(
            "cyborg_public_module", [SYSTEM_PYTHON, str(MODULE)], "public package module ready", env=env
        )
        idle = processes.cyborg_node("cyborg_test_idle", MACHINE, tmp_path, env=env)
        processes.wait_ready(module, idle)
        controller = processes.cyborg_node("cyborg_controller", MACHINE, tmp_path, env=env)
        processes.wait_ready(controller)
        results.wait_connected()
        events = observe.events()
        changes.wait_state("idle", event="start")
        events.wait_connected()

        # An emotion the module can only report if the service answered its 'nothing' request.
        deadline = time.monotonic() + 10
        while set_emotion.get_num_connections() < 1:
            assert time.monotonic() < deadline, "the emotion system did not subscribe to set_emotional_state"
            time.sleep(0.01)
        initial = emotions.wait_for(lambda h: True, what="the latched emotion").message.to_emotional_state
        mark = emotions.mark()
        set_emotion.publish(String(data="happy"))
        emotion = emotions.wait_for(
            lambda h: True, after=mark, what="the new emotion"
        ).message.to_emotional_state
        assert emotion != initial, f"setting 'happy' left the emotion at {initial!r}"

        # The controller enters the module's state: the goal carries order EXECUTE, the module asks
        # the emotional-state service, succeeds, and the controller acts on that result.
        mark = changes.mark()
        events.send("visit")
        changes.wait_state("idle", event="succeeded", after=mark)
        assert changes.path(mark) == [
            ("idle", "visit", "public_module"),
            ("public_module", "succeeded", "idle"),
        ], processes.logs()
        result = results.wait_for(lambda h: h.message.result.status == "done", what="the module's result")
        assert result.sender == "cyborg_public_module"
        assert result.message.status.status == GoalStatus.SUCCEEDED
        assert result.message.result.message == f"order=EXECUTE emotion={emotion}", processes.logs()
        assert module.process.poll() is None and controller.process.poll() is None
    finally:
        set_emotion.unregister()
