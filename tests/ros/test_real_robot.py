"""The real robot's configuration over ROS 1, against a base that is not ours, checked by the doctor.

The test writes its own stand-in for ROSARNL: a plain rospy node ``rosarnl_node`` with the
``move_base`` action, the ``wander`` and ``stop`` services and ``amcl_pose``, that drives in a
straight line (fast: this is no simulation of the Pioneer). ``cyborg launch --config robot``
starts the robot (no simulated base) with ALSA's null device as its speaker and microphone; the
robot guides a person to the cafeteria with it. ``cyborg doctor --ros`` passes on that graph,
then names each part removed in turn: a module node, the base, the speech output.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from cyborg.app.config import load_config, packaged_config
from cyborg.app.parts import part_names
from cyborg.maps import default_map_path, load_map
from tests.support.ros import Observers, Processes, free_port
from tests.support.sound import alsa_home

STAND_IN_BASE = '''
"""A stand-in for ROSARNL: move_base, wander, stop and amcl_pose, in plain rospy."""
import math
import sys
import threading

import actionlib
import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseResult
from std_srvs.srv import Empty, EmptyResponse

SPEED = 25.0  # m/s: a stand-in, not a Pioneer
RATE = 10.0  # poses a second, as ROSARNL's
rospy.init_node("rosarnl_node")
where = [float(sys.argv[1]), float(sys.argv[2])]
lock = threading.Lock()
pose_pub = rospy.Publisher("/rosarnl_node/amcl_pose", PoseWithCovarianceStamped, queue_size=10, latch=True)


def publish():
    message = PoseWithCovarianceStamped()
    message.header.stamp = rospy.Time.now()
    message.header.frame_id = "map"
    with lock:
        message.pose.pose.position.x, message.pose.pose.position.y = where
    message.pose.pose.orientation.w = 1.0
    pose_pub.publish(message)


def execute(goal):
    target = goal.target_pose.pose.position
    rate = rospy.Rate(RATE)
    while not rospy.is_shutdown():
        if server.is_preempt_requested():
            server.set_preempted()
            return
        with lock:
            dx, dy = target.x - where[0], target.y - where[1]
            left = math.hypot(dx, dy)
            step = min(1.0, SPEED / RATE / left) if left > 0 else 1.0
            where[0] += dx * step
            where[1] += dy * step
        publish()
        if left <= SPEED / RATE:
            server.set_succeeded(MoveBaseResult())
            return
        rate.sleep()


server = actionlib.SimpleActionServer("/rosarnl_node/move_base", MoveBaseAction, execute, auto_start=False)
server.start()
rospy.Service("/rosarnl_node/wander", Empty, lambda request: EmptyResponse())
rospy.Service("/rosarnl_node/stop", Empty, lambda request: EmptyResponse())
print("stand-in base ready", flush=True)
rate = rospy.Rate(RATE)
while not rospy.is_shutdown():
    publish()
    rate.sleep()
'''

SEPARATE = ("cyborg_joke", "cyborg_tts")
"""Parts started on their own, so that the test can take them away (the launch restarts its own)."""


def _doctor(env: dict[str, str], data: Path) -> tuple[dict[str, Any], float]:
    command = [sys.executable, "-m", "cyborg.cli", "doctor", "--ros", "--config", "robot", "--db", str(data)]
    started = time.monotonic()
    done = subprocess.run([*command, "--json"], capture_output=True, text=True, env=env, timeout=60)
    took = time.monotonic() - started
    assert done.returncode in (0, 1), done.stderr[-3000:]
    report = json.loads(done.stdout)
    assert report["passed"] is (done.returncode == 0)
    return report, took


def _failed(report: dict[str, Any]) -> dict[str, str]:
    return {
        c["name"]: c["detail"] + " / fix: " + c["fix"] for c in report["checks"] if c["status"] == "failed"
    }


def test_the_real_robot_guides_a_person_with_a_rospy_base_and_the_doctor_names_what_is_missing(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    import rospy  # type: ignore[import-not-found]
    from geometry_msgs.msg import PoseWithCovarianceStamped  # type: ignore[import-not-found]
    from std_msgs.msg import String  # type: ignore[import-not-found]

    from cyborg.transport.ros.master import listed_subscribers

    campus = load_map(default_map_path())
    desk, cafeteria = campus.pose("information desk"), campus.pose("cafeteria")
    env = {**os.environ, "XDG_CONFIG_HOME": str(alsa_home(tmp_path / "sound", device=True))}
    data = tmp_path / "data"
    script = tmp_path / "stand_in_base.py"
    script.write_text(STAND_IN_BASE, encoding="utf-8")
    changes = observe.state_changes()
    spoken = observe.topic("/cyborg_tts/spoken", String)
    poses = observe.topic("/rosarnl_node/amcl_pose", PoseWithCovarianceStamped)
    base = processes.start(
        "stand_in_base",
        [sys.executable, str(script), str(desk.x), str(desk.y)],
        "stand-in base ready",
        env=env,
    )
    robot = load_config(packaged_config("robot.yaml"))
    parts = [f"--only={part}" for part in part_names(robot) if part not in SEPARATE]
    where = ["--config", "robot", "--db", str(data), "--map", str(default_map_path())]
    launch = [sys.executable, "-m", "cyborg.cli", "launch", *where]
    processes.start(
        "launch", [*launch, "--port", str(free_port()), *parts], "launched", env=env, new_session=True
    )
    separate = [
        processes.start(
            name,
            [sys.executable, "-m", "cyborg.cli", "node", name, *where],
            f"node {name} running",
            env=env,
        )
        for name in SEPARATE
    ]
    processes.wait_ready(base, *separate, timeout=60)
    changes.wait_state("idle", timeout=60)

    # The doctor passes on the whole graph: every check, each line with its time.
    report, took = _doctor(env, data)
    assert report["passed"], _failed(report)
    names = {c["name"] for c in report["checks"]}
    assert "robot base: action /rosarnl_node/move_base" in names and "microphone (cyborg_speech)" in names
    print(f"doctor on a healthy graph: {took:.1f} s;", {c["name"]: c["seconds"] for c in report["checks"]})

    # A person asks for the cafeteria, says yes, and is guided there by the stand-in base.
    speech = rospy.Publisher("/text_from_speech", String, queue_size=10)
    listeners = listed_subscribers("/text_from_speech")
    assert {"cyborg_conversation", "cyborg_navigation"} <= {n.lstrip("/") for n in listeners}, listeners
    deadline = time.monotonic() + 10
    while speech.get_num_connections() < len(listeners) and time.monotonic() < deadline:
        time.sleep(0.05)
    mark = changes.mark()
    said = spoken.mark()
    speech.publish(String(data="hello"))
    changes.wait_state("conversation", after=mark, timeout=20)
    speech.publish(String(data="where is the cafeteria"))
    spoken.wait_for(lambda h: "show you" in h.message.data, after=said, timeout=20, what="the offer")
    speech.publish(String(data="yes"))
    changes.wait_state("navigation_moving", event="navigation_start_moving", after=mark, timeout=20)
    changes.wait_state("navigation_talking", event="succeeded", after=mark, timeout=30)

    def at_cafeteria(heard: Any) -> bool:
        position = heard.message.pose.pose.position
        return math.dist((position.x, position.y), cafeteria.position) < 0.5

    poses.wait_for(at_cafeteria, timeout=10, what="the base's pose at the cafeteria")
    assert {h.sender for h in spoken.since(said)} == {"cyborg_tts"}

    # Each part taken away is named by the doctor, each run well within 10 s. The module is
    # killed (the master still lists it: the doctor asks the node itself), the others stopped.
    try:
        for victim, named in (
            (separate[0], "state joke: action server /cyborg_joke/ask"),
            (base, "robot base: action /rosarnl_node/move_base"),
            (separate[1], "speech output node cyborg_tts"),
        ):
            if victim is separate[0]:
                victim.kill()
            else:
                victim.stop()
            report, took = _doctor(env, data)
            failed = _failed(report)
            assert named in failed, failed
            assert "fix: start" in failed[named], failed[named]
            # Its own time (joining the graph and every check; the interpreter's start is the machine's).
            spent = report["seconds"]
            assert spent < 10.0, f"the doctor took {spent:.1f} s to name {victim.name}"
            print(f"doctor without {victim.name}: {spent:.1f} s of checks, {took:.1f} s in all")
        assert "(cyborg_joke registered but not answering)" in failed["configured nodes"], failed
    finally:  # the killed node's registrations would hold up later tests' nodes (rosnode cleanup)
        import rosgraph  # type: ignore[import-not-found]
        import rosnode  # type: ignore[import-not-found]

        rosnode.cleanup_master_blacklist(rosgraph.Master("/cyborg_tests"), ["/cyborg_joke"])
