"""Issue 31, items 1 and 10: a robot keeps its ROS graph, against strangers and other robots.

The attacks of the review (10.6-10.11, 7.6), against launched graphs:

- ROS 2: a robot launched on a domain; a stranger (plain rclpy, ros2_stranger.py) publishes a
  fake state change, a sentence straight to the text-to-speech and a 1 MB "sentence" as heard;
  then a second robot is launched on the same domain. Before, the dashboard showed the fake
  state as the robot's, the robot spoke the stranger's sentence, the 1 MB text went to every
  module and record, and the second robot merged with the first without a word.
- ROS 2 without a deliberate domain: refused before any node starts.
- ROS 1: a second ``cyborg node`` of a name that runs. Before, the master shut the first down
  and the second took its place silently.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import signal
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.support.paths import ROOT
from tests.support.ros import Processes, free_port, ros_session

HERE = Path(__file__).resolve().parent
CONFIG = HERE / "graph_robot.yaml"
STRANGER = HERE / "ros2_stranger.py"
NAME_TAKEN_EXIT = 76  # cyborg node's exit code for a name in use (cyborg.run.census)


def ros2_python() -> str:
    from cyborg.run.ros2_env import ros2_python as find

    return find()


def ros2_env(tmp_path: Path, domain: int | None) -> dict[str, str]:
    """The environment of a ROS 2 process of this checkout, discovery on this machine."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_") and k != "VIRTUAL_ENV"}
    env.update(PYTHONPATH=str(ROOT / "src"), ROS_LOG_DIR=str(tmp_path / "log"), NO_COLOR="1")
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    if domain is not None:
        env["ROS_DOMAIN_ID"] = str(domain)
    return env


def get(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=5) as response:
        return json.loads(response.read())


def launch_command(port: int, data: Path, *extra: str) -> list[str]:
    command = [ros2_python(), "-m", "cyborg.cli", "launch", "--ros2", "--config", str(CONFIG)]
    return [*command, "--port", str(port), "--db", str(data), *extra]


@pytest.fixture
def robot_a(tmp_path: Path) -> Iterator[tuple[str, dict[str, str]]]:
    """A launched ROS 2 robot on a domain of the test's own, until its API shows idle: (its API, env)."""
    env = ros2_env(tmp_path, random.randint(150, 232))
    port = free_port()
    process = subprocess.Popen(
        launch_command(port, tmp_path / "a"),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
        start_new_session=True,
    )
    api = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 120
        while True:
            assert process.poll() is None, process.communicate()[0][-3000:]
            with contextlib.suppress(OSError, ValueError):
                if get(f"{api}/api/status").get("state") == "idle":
                    break
            assert time.monotonic() < deadline, "robot A's API did not show the idle state within 120 s"
            time.sleep(0.3)
        yield api, env
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGINT)
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait(timeout=10)


@pytest.mark.ros2
@pytest.mark.slow
def test_ros2_a_robot_believes_no_stranger_and_a_second_robot_on_its_domain_refuses_to_start(
    robot_a: tuple[str, dict[str, str]], tmp_path: Path
) -> None:
    api, env = robot_a
    domain = env["ROS_DOMAIN_ID"]
    assert get(f"{api}/api/status")["graph"] == f"ROS 2 domain {domain} (discovery: this machine only)"

    stranger = subprocess.run(
        [ros2_python(), str(STRANGER)],
        capture_output=True,
        text=True,
        env={**env, "PYTHONPATH": ""},
        timeout=90,
    )
    assert stranger.returncode == 0, stranger.stdout + stranger.stderr[-2000:]
    time.sleep(1.0)
    assert get(f"{api}/api/status")["state"] == "idle"
    assert get(f"{api}/api/health")["active_state"] == "idle"
    states = get(f"{api}/api/records?type=state")
    assert [r["to"] for r in states] == ["idle"], states
    assert not get(f"{api}/api/records?type=say"), "the robot spoke what a stranger put behind the gatekeeper"
    assert all(len(r["text"]) <= 2000 for r in get(f"{api}/api/records?type=heard"))

    # The second robot: its controller is enough (and spares the loaded machine four processes).
    second = subprocess.run(
        launch_command(free_port(), tmp_path / "b", "--only", "cyborg_controller"),
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    output = second.stdout + second.stderr
    assert second.returncode == 1, output[-3000:]
    assert f"another robot runs on ROS 2 domain {domain}" in output, output[-3000:]
    assert "fix: stop that robot, or give this one a graph of its own" in output
    assert [r["to"] for r in get(f"{api}/api/records?type=state")] == ["idle"]  # A saw nothing of B


@pytest.mark.ros2
def test_ros2_a_launch_without_a_deliberate_domain_is_refused_before_any_node_starts(tmp_path: Path) -> None:
    env = ros2_env(tmp_path, None)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SUBNET"
    done = subprocess.run(
        launch_command(free_port(), tmp_path / "data", "--duration", "1"),
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    assert done.returncode == 1, done.stdout + done.stderr
    assert "ROS_DOMAIN_ID is not set: this robot would join ROS 2 domain 0" in done.stderr
    assert "launched" not in done.stdout


@pytest.mark.ros
def test_ros1_a_second_node_of_a_running_name_refuses_instead_of_replacing_it(
    pytestconfig: pytest.Config, tmp_path: Path
) -> None:
    ros_session(pytestconfig)  # the session's roscore, ROS_MASTER_URI pointing at it
    processes = Processes(tmp_path)
    try:
        first = processes.cyborg_node("cyborg_test_idle", CONFIG, tmp_path / "db")
        processes.wait_ready(first)
        command = [sys.executable, "-m", "cyborg.cli", "node", "cyborg_test_idle", "--config", str(CONFIG)]
        try:
            second = subprocess.run(
                [*command, "--db", str(tmp_path / "db2")], capture_output=True, text=True, timeout=30
            )
        except subprocess.TimeoutExpired:
            pytest.fail(
                "the second cyborg_test_idle started beside the first (the master shut the first down)"
            )
        master = os.environ["ROS_MASTER_URI"]
        assert second.returncode == NAME_TAKEN_EXIT, second.stderr[-2000:]
        assert f"a node /cyborg_test_idle already runs on ROS 1 master {master}" in second.stderr
        assert first.process.poll() is None, "the first node was stopped"
    finally:
        processes.stop_all()
