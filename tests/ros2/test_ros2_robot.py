"""The whole robot on ROS 2, as a user runs it: every part its own ``cyborg node --ros2`` process.

``cyborg sim --ros2 --script FILE`` plays the thesis's four scenarios (10.2) on the robot's ROS 2
nodes in lockstep time (``--speed max``), the simulated base publishing it on
/clock; the transcript must pass the checks of the embedded and ROS 1 runs
(tests/scenarios/expectations.py, and the scripts' own ``expect:`` steps, which fail the run),
and its state, say, heard and emotion records must be the embedded run's, to the nanosecond.
``cyborg launch --ros2`` starts the robot with its API node; the command tool (``--ros2``) and
the HTTP API drive and read it. Runs in .venv-ros2 (tests/ros2/conftest.py), on this process's
ROS_DOMAIN_ID, discovery on this host.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from datetime import UTC
from pathlib import Path
from typing import Any

import pytest

from cyborg.sim.scenario import script_start
from cyborg.sim.script import load_script
from cyborg.transport.base import MessageInfo
from cyborg.transport.messages import Clock, String
from tests.scenarios.expectations import check_transcript
from tests.support.paths import ROOT, SCENARIOS
from tests.support.ros2 import Ros2Session, isolate
from tests.support.transcripts import assert_same_as_in_process

TOOLS = Path(__file__).resolve().parent / "tools.yaml"


# B runs over ROS 1 and in process only: the suite's time pays for A, C and D over ROS 2.
@pytest.mark.parametrize("name", ["scenario_a", "scenario_c", "scenario_d"])
def test_ros2_scenario(name: str, own_session: Ros2Session, tmp_path: Path) -> None:
    # The robot and this process (to hear /clock) on a domain of the test's own: on the session's
    # domain the contract suite's parameter home and nodes were there too, and scenario A's
    # scripted user went unheard in 3 of 3 runs after the suite (never when run alone).
    session = own_session
    heard: list[tuple[float, str]] = []

    def on_clock(message: Clock, info: MessageInfo) -> None:
        heard.append((message.clock, info.sender))

    observer = session.transport.node(f"clock_observer_{name}")
    observer.subscribe("/clock", Clock, on_clock, queue_size=1000)
    script_path = SCENARIOS / f"{name}.yaml"
    script = load_script(script_path)
    transcript = tmp_path / "transcript.jsonl"
    command = [sys.executable, "-m", "cyborg.cli", "sim", "--ros2", "--script", str(script_path)]
    command += ["--speed", "max", "--transcript", str(transcript), "--db", str(tmp_path / "data")]
    env = {**os.environ, "ROS_LOG_DIR": str(tmp_path / "log")}
    try:  # the session's loop runs meanwhile: it is where /clock's callbacks run
        result = session.clock.run(
            asyncio.to_thread(subprocess.run, command, capture_output=True, text=True, timeout=300, env=env)
        )
    finally:
        observer.shutdown()
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    records = [json.loads(line) for line in transcript.read_text().splitlines()]
    check_transcript(name, records, transcript)
    assert_same_as_in_process(name, records)
    assert records[-1]["t"] <= script.until + 1
    assert "in lockstep" in result.stdout and f"wrote {len(records)} records" in result.stdout
    assert "written off" not in result.stdout + result.stderr, "every message was counted in and out"
    assert re.search(r"cyborg_scenario: (\d+) of \1 expectations? met", result.stdout), result.stdout[-2000:]

    # Simulated time on /clock, from the simulated base's process, starting at the script's start.
    assert heard, "nothing was published on /clock"
    assert {sender for _, sender in heard} == {"rosarnl_node_clock"}
    stamps = [stamp for stamp, _ in heard]
    assert stamps == sorted(stamps)
    start = script_start(script).astimezone(UTC).timestamp()
    assert start <= stamps[0] < start + 60
    assert stamps[-1] - stamps[0] >= 0.8 * script.until


def test_ros2_nodes_follow_clock_with_use_sim_time() -> None:
    """Under --speed every rclpy node has use_sim_time: its own clock reads what /clock says."""
    isolate()
    from rclpy.clock import ClockType

    from cyborg.transport.clock import RealClock
    from cyborg.transport.ros2 import Ros2Transport

    clock = RealClock()
    simulated = Ros2Transport(clock, use_sim_time=True)
    try:
        node = simulated.node("follows_clock")
        publisher = simulated.node("publishes_clock").publisher("/clock", Clock, queue_size=1)
        rcl_clock = node.rcl.get_clock()  # type: ignore[attr-defined]
        assert rcl_clock.clock_type == ClockType.ROS_TIME
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            publisher.publish(Clock(clock=1_795_424_400.25))
            time.sleep(0.05)
            if abs(rcl_clock.now().nanoseconds / 1e9 - 1_795_424_400.25) < 1e-6:
                break
        assert rcl_clock.now().nanoseconds / 1e9 == pytest.approx(1_795_424_400.25, abs=1e-6)
    finally:
        simulated.close()
        clock.close()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _get(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=5) as response:
        return json.loads(response.read())


@pytest.fixture
def own_domain(monkeypatch: pytest.MonkeyPatch) -> None:
    """A ROS 2 domain of this test's own for the launched robot, the tools and the test's listener.

    This process's session has hosted the parameter home (``/cyborg_parameters``) since the
    contract suite, holding other machines' transitions; on the session's domain the tool may ask
    that home instead of the launched controller's. The runner picks domains 1-100, so +100 is free.
    """
    monkeypatch.setenv("ROS_DOMAIN_ID", str(int(os.environ.get("ROS_DOMAIN_ID", "0")) + 100))


@pytest.fixture
def own_session(own_domain: None) -> Iterator[Ros2Session]:
    """A ROS 2 transport in this process on the test's own domain."""
    session = Ros2Session()
    yield session
    session.close()


@pytest.fixture
def launched(tmp_path: Path, own_domain: None) -> Iterator[tuple[subprocess.Popen[str], int]]:
    """`cyborg launch --ros2` of TOOLS (real time, its API on a free port), until the API shows idle."""
    port = _free_port()
    env = {**os.environ, "ROS_LOG_DIR": str(tmp_path / "log")}
    command = [sys.executable, "-m", "cyborg.cli", "launch", "--ros2", "--config", str(TOOLS)]
    command += ["--port", str(port), "--db", str(tmp_path / "data")]
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 120
        while True:
            assert process.poll() is None, process.communicate()[0][-3000:]
            with contextlib.suppress(OSError, ValueError):
                if _get(f"http://127.0.0.1:{port}/api/status").get("state") == "idle":
                    break
            assert time.monotonic() < deadline, "the robot's API did not show the idle state within 120 s"
            time.sleep(0.3)
        yield process, port
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait(timeout=10)


def _tool(*args: str, python: str = sys.executable) -> subprocess.CompletedProcess[str]:
    command = [python, "-m", "cyborg.cli", *args, "--ros2"]
    return subprocess.run(command, capture_output=True, text=True, timeout=60)


def _wait_state(api: str, state: str) -> None:
    deadline = time.monotonic() + 20
    while _get(f"{api}/api/status")["state"] != state:
        assert time.monotonic() < deadline, _get(f"{api}/api/status")
        time.sleep(0.1)


def test_ros2_command_tool_and_api_drive_a_launched_robot(
    launched: tuple[subprocess.Popen[str], int], own_session: Ros2Session, tmp_path: Path
) -> None:
    process, port = launched
    api = f"http://127.0.0.1:{port}"
    heard: list[tuple[str, str]] = []
    session = own_session
    listener = session.transport.node("speech_listener")
    listener.subscribe("/text_from_speech", String, lambda m, i: heard.append((m.data, i.sender)))

    status = _tool("status")
    assert status.returncode == 0, status.stderr
    assert (
        status.stdout == "- --start--> idle   emotion neutral (P +0.00 A +0.00 D +0.00)   emotion system on\n"
    )

    said = session.clock.run(asyncio.to_thread(_tool, "say", "hello", "there"))  # the loop hears meanwhile
    assert said.returncode == 0, said.stderr
    assert said.stdout.startswith("heard: hello there (by "), said.stdout

    async def delivered() -> None:  # callbacks run on the session's loop: run it until the message is in
        for _ in range(100):
            if heard:
                return
            await asyncio.sleep(0.05)

    session.clock.run(delivered())
    assert heard == [("hello there", "cyborg_tool")]
    listener.shutdown()

    dropped = _tool("event", "no_such_event")
    assert dropped.returncode == 0, dropped.stderr
    assert (
        dropped.stdout
        == "sent event no_such_event (not a transition of the current state: it will be dropped)\n"
    )

    sent = _tool("event", "work")
    assert sent.returncode == 0, sent.stderr
    assert sent.stdout == "sent event work\n", "a transition of idle: no warning"
    _wait_state(api, "working")
    status = _tool("status")
    assert status.stdout.startswith("idle --work--> working   emotion neutral"), status.stdout

    # The API node (the dashboard's) mirrors the robot over ROS 2.
    health = _get(f"{api}/api/health")
    assert (health["active_state"], health["previous_state"], health["last_event"]) == (
        "working",
        "idle",
        "work",
    )
    assert health["emotion_enabled"] is True
    assert health["stats"]["handovers"] == 2
    assert _get(f"{api}/api/status")["valid_events"] == ["aborted", "succeeded"]

    # The launch's recorder node records over ROS 2; the dashboard marks a moment and looks back.
    recorder = _get(f"{api}/api/recorder")
    assert recorder["recording"] is True, recorder
    mark = urllib.request.Request(
        f"{api}/api/mark", data=b'{"note": "while working"}', headers={"Content-Type": "application/json"}
    )
    with urllib.request.urlopen(mark, timeout=5) as answer:
        assert json.loads(answer.read())["marked"] == "while working"
    back: dict[str, Any] = {}
    for _ in range(50):  # the mark goes over the graph to the recorder
        back = _get(f"{api}/api/lookback/replay?minutes=5")
        if back["marks"]:
            break
        time.sleep(0.1)
    assert [m["note"] for m in back["marks"]] == ["while working"], back
    assert _get(f"{api}/api/lookback/status")["state"] == "working"

    # Typed in the main venv (ROS 1's), a --ros2 command runs again in .venv-ros2 by itself.
    main_python = ROOT / ".venv" / "bin" / "python"
    assert main_python.exists(), "the main venv is where users type cyborg"
    status = _tool("status", python=str(main_python))
    assert status.returncode == 0, status.stderr
    assert status.stdout.startswith("idle --work--> working"), status.stdout

    process.send_signal(signal.SIGINT)
    output = process.communicate(timeout=30)[0]
    assert process.returncode == 0, output[-3000:]
    assert (
        "launched 5 nodes in 3 processes: cyborg_controller, cyborg_test_idle (with cyborg_test_worker), "
        "cyborg_api (with cyborg_recorder)" in output  # ROS 2: thin parts share one, API and recorder one
    )
    assert "stopping" in output and "Traceback" not in output, output[-3000:]

    # Every node's lines are where the launch says: NODE.log; the worker shares the idle module's
    # process, so its NODE.log leads to that process's file.
    logs = tmp_path / "log"
    assert (
        f"every log line is in {logs}/NODE.log; cyborg_test_idle's process also runs cyborg_test_worker: "
        "their lines are in cyborg_test_idle.log, which their NODE.log links to" in output
    ), output[:3000]
    assert "cyborg_api's process also runs cyborg_recorder: their lines are in cyborg_api.log" in output
    nodes = ("cyborg_controller", "cyborg_recorder", "cyborg_test_idle", "cyborg_test_worker", "cyborg_api")
    missing = [name for name in nodes if not (logs / f"{name}.log").is_file()]
    assert not missing, f"no log file for {missing} in {sorted(p.name for p in logs.iterdir())}"
    assert (logs / "cyborg_test_worker.log").resolve() == (logs / "cyborg_test_idle.log").resolve()
    assert (logs / "cyborg_recorder.log").resolve() == (logs / "cyborg_api.log").resolve()
    assert "the emotion system starts neutral" in (logs / "cyborg_controller.log").read_text()
