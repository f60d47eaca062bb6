"""The real robot's configuration over ROS 2, against a base written in plain rclpy, and the doctor.

Runs in .venv-ros2 (tests/ros2/test_in_ros2_venv.py starts it). The test writes its own base: an
rclpy node ``rosarnl_node`` serving ``/navigate_to_pose`` (our NavigateToPose interface: ROSARNL
has no ROS 2 port and std_srvs/move_base_msgs have no wheels, so the ROS 2 robot drives a base
through nav2's action, docs/ros2.md) and publishing ``/rosarnl_node/amcl_pose``. ``cyborg
launch --ros2 --config robot`` starts the robot with ALSA's null device as its speaker and
microphone; ``cyborg doctor --ros2`` passes on that graph; the robot guides a person to the
cafeteria.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from cyborg.app.config import load_config, packaged_config
from cyborg.app.parts import CONTROLLER
from cyborg.maps import default_map_path, load_map
from cyborg.transport import topics
from cyborg.transport.messages import PoseWithCovarianceStamped, String, SystemState
from tests.support.ros2 import Ros2Session
from tests.support.sound import alsa_home

STAND_IN_BASE = '''
"""A stand-in robot base in plain rclpy: /navigate_to_pose and /rosarnl_node/amcl_pose."""
import math
import sys
import threading
import time

import rclpy
from cyborg_controller.action import NavigateToPose
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile

SPEED = 25.0  # m/s: a stand-in, not a Pioneer
RATE = 10.0


class Base(Node):
    def __init__(self, x, y):
        super().__init__("rosarnl_node")
        self.where = [x, y]
        self.lock = threading.Lock()
        qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.pose = self.create_publisher(PoseWithCovarianceStamped, "/rosarnl_node/amcl_pose", qos)
        self.server = ActionServer(
            self, NavigateToPose, "/navigate_to_pose", execute_callback=self.execute,
            goal_callback=lambda goal: GoalResponse.ACCEPT,
            cancel_callback=lambda handle: CancelResponse.ACCEPT,
            callback_group=ReentrantCallbackGroup(),
        )
        self.create_timer(1.0 / RATE, self.publish)

    def publish(self):
        message = PoseWithCovarianceStamped()
        message.header.frame_id = "map"
        message.header.stamp = self.get_clock().now().to_msg()
        with self.lock:
            message.pose.pose.position.x, message.pose.pose.position.y = self.where
        message.pose.pose.orientation.w = 1.0
        self.pose.publish(message)

    def execute(self, handle):
        target = handle.request.pose.pose.position
        while True:
            if handle.is_cancel_requested:
                handle.canceled()
                return NavigateToPose.Result()
            with self.lock:
                dx, dy = target.x - self.where[0], target.y - self.where[1]
                left = math.hypot(dx, dy)
                step = min(1.0, SPEED / RATE / left) if left > 0 else 1.0
                self.where[0] += dx * step
                self.where[1] += dy * step
            self.publish()
            if left <= SPEED / RATE:
                handle.succeed()
                return NavigateToPose.Result()
            time.sleep(1.0 / RATE)


rclpy.init()
base = Base(float(sys.argv[1]), float(sys.argv[2]))
executor = MultiThreadedExecutor()
executor.add_node(base)
print("stand-in base ready", flush=True)
try:
    executor.spin()
except KeyboardInterrupt:
    pass
'''


def _stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=10)


def _wait_line(log: Path, line: str, process: subprocess.Popen[bytes], timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while line not in log.read_text(errors="replace"):
        assert process.poll() is None, log.read_text(errors="replace")[-3000:]
        assert time.monotonic() < deadline, f"no {line!r} within {timeout} s:\n" + log.read_text()[-3000:]
        time.sleep(0.1)


def test_ros2_real_robot_guides_a_person_with_an_rclpy_base(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", str(int(os.environ.get("ROS_DOMAIN_ID", "0")) + 100))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(alsa_home(tmp_path / "sound", device=True)))
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path / "log"))
    campus = load_map(default_map_path())
    desk, cafeteria = campus.pose("information desk"), campus.pose("cafeteria")
    data = tmp_path / "data"
    script = tmp_path / "stand_in_base.py"
    script.write_text(STAND_IN_BASE, encoding="utf-8")
    started: list[subprocess.Popen[bytes]] = []

    def start(name: str, command: list[str]) -> tuple[subprocess.Popen[bytes], Path]:
        log = tmp_path / f"{name}.log"
        with log.open("wb") as out:
            process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        started.append(process)
        return process, log

    session = Ros2Session()
    try:
        node = session.transport.node("test_person")
        states: list[tuple[str, str, str]] = []
        said: list[str] = []
        poses: list[tuple[float, float]] = []
        node.subscribe(
            topics.STATE_CHANGE,
            SystemState,
            lambda m, i: states.append((m.from_system_state, m.event, m.to_system_state)),
        )
        node.subscribe(topics.SPOKEN_TOPIC, String, lambda m, i: said.append(m.data))
        node.subscribe(
            topics.AMCL_POSE,
            PoseWithCovarianceStamped,
            lambda m, i: poses.append((m.pose.pose.position.x, m.pose.pose.position.y)),
        )
        speech = node.publisher(topics.TEXT_FROM_SPEECH, String, latch=False)
        base, base_log = start("base", [sys.executable, str(script), str(desk.x), str(desk.y)])
        where = ["--config", "robot", "--db", str(data), "--map", str(default_map_path())]
        launch, launch_log = start(
            "launch", [sys.executable, "-m", "cyborg.cli", "launch", "--ros2", *where, "--port", "0"]
        )
        _wait_line(base_log, "stand-in base ready", base, 60)

        async def until(what: str, condition: Callable[[], bool], timeout: float) -> None:
            deadline = time.monotonic() + timeout
            while not condition():
                assert launch.poll() is None, launch_log.read_text(errors="replace")[-3000:]
                assert time.monotonic() < deadline, (
                    f"no {what} within {timeout} s; states {states}, said {said}; the launch:\n"
                    + launch_log.read_text(errors="replace")[-3000:]
                )
                await asyncio.sleep(0.1)

        def wait(what: str, condition: Callable[[], bool], timeout: float = 60.0) -> None:
            """Wait on the session's loop, which delivers what the test's node hears."""
            session.clock.run(until(what, condition, timeout))

        wait("idle", lambda: any(to == "idle" for _, _, to in states), 90)
        # The robot is idle once the controller and the idle module are up; the heavier nodes
        # (navigation loads its places and its understanding) may still be starting.
        robot = load_config(packaged_config("robot.yaml")).model
        parts = {CONTROLLER, *robot.modules, *(g.name for g in robot.gatekeepers)}
        wait("every node", lambda: parts <= session.transport.graph_node_names(), 90)

        # The doctor passes on the launched graph.
        doctor = [sys.executable, "-m", "cyborg.cli", "doctor", "--ros2", *where[:4], "--json"]
        began = time.monotonic()
        done = subprocess.run(doctor, capture_output=True, text=True, timeout=60)
        report = json.loads(done.stdout)
        failed = {c["name"]: c["detail"] for c in report["checks"] if c["status"] == "failed"}
        assert done.returncode == 0 and not failed, (failed, done.stderr[-2000:])
        assert "robot base: action /navigate_to_pose" in {c["name"] for c in report["checks"]}
        print(f"doctor --ros2 on a healthy graph: {time.monotonic() - began:.1f} s")

        # A person greets the robot, asks for the cafeteria, says yes, and is guided there.
        wait("listeners", lambda: speech.subscriber_count() >= 2, 20)
        mark = len(states)
        speech.publish(String("hello"))
        wait("the conversation", lambda: any(to == "conversation" for _, _, to in states[mark:]), 20)
        # As a person would: asked while the robot asks its own question (the conversation module
        # may start one at once, sooner on a loaded machine), the question is asked again once
        # the robot is back in the conversation.
        for attempt in range(3):
            wait("the conversation", lambda: bool(states) and states[-1][2] == "conversation", 40)
            heard = len(said)
            speech.publish(String("where is the cafeteria"))

            def offered(since: int = heard) -> bool:
                return any("show you" in s for s in said[since:])

            try:
                wait("the offer", offered, 20)
                break
            except AssertionError:
                if attempt == 2:
                    raise
        speech.publish(String("yes"))
        wait(
            "the trip", lambda: ("navigation_moving", "succeeded", "navigation_talking") in states[mark:], 40
        )
        assert ("navigation_planning", "navigation_start_moving", "navigation_moving") in states[mark:]
        assert math.dist(poses[-1], cafeteria.position) < 0.5, poses[-1]
    finally:
        for process in reversed(started):
            _stop(process)
        session.close()
