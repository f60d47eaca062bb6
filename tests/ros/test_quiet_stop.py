"""A ROS 1 ``cyborg launch`` that is stopped normally says goodbye without a traceback.

Ctrl-C in the launch's terminal sends SIGINT to the launch and to every node it started (one
process group); a ``kill`` sends it to the launch alone, which stops its nodes. Either way what
the terminal shows on the way down is the nodes stopping, not "Traceback" (rospy's "publish()
to a closed topic", a motivator decision that failed while the node went down).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from cyborg.cli import cli
from cyborg.observe.recording import open_recording
from cyborg.transport.messages import StateMachineAction
from tests.support.paths import SCENARIOS
from tests.support.ros import Observers, Processes, RosSession, yaml_path

CONFIG = yaml_path("quiet_stop.yaml")
SCENARIO_D = SCENARIOS / "scenario_d.yaml"


@pytest.mark.parametrize(
    ("group", "signum"),
    [(True, signal.SIGINT), (False, signal.SIGINT), (False, signal.SIGTERM)],
    ids=["ctrl-c", "sigint-to-launch", "sigterm-to-launch"],
)
def test_a_launch_stopped_normally_prints_no_traceback(
    processes: Processes, observe: Observers, tmp_path: Path, group: bool, signum: signal.Signals
) -> None:
    changes = observe.state_changes()
    # With Ctrl-C the flight recorder's node is launched too: it must finish its file on the way down.
    parts = ("cyborg_controller", "cyborg_idle", *(("cyborg_recorder",) if group else ()))
    only = [arg for part in parts for arg in ("--only", part)]
    command = [sys.executable, "-m", "cyborg.cli", "launch", "--config", str(CONFIG), "--db", str(tmp_path)]
    record = ["--record", str(tmp_path / "launch.mcap")] if group else []
    launch = processes.start(
        "cyborg_launch",
        [*command, *only, *record],
        f"launched {len(parts)} nodes",
        env={**os.environ, "ROS_HOME": str(tmp_path / "ros_home")},
        new_session=True,
    )
    processes.wait_ready(launch, timeout=60)
    changes.wait_state("idle", event="start", timeout=60)
    if group:  # an event from outside, and another node's warning, for the recording
        import rospy
        from rosgraph_msgs.msg import Log  # type: ignore[import-not-found]

        warnings = observe.topic("/rosout_agg", Log)
        sender = observe.events()
        sender.wait_connected()
        sender.wait_connected("/cyborg_recorder")  # else the event is not recorded, and the re-run differs
        sender.send("aborted")
        changes.wait_state("idle", event="aborted", timeout=30)
        rospy.logwarn("the camera's lens is dirty")
        warnings.wait_for(lambda h: "lens is dirty" in h.message.msg, timeout=30)
    time.sleep(2.0)  # the motivator decides and the idle goal runs: the robot is busy as usual
    if group:
        os.killpg(launch.pid, signum)
    else:
        launch.process.send_signal(signum)
    assert launch.process.wait(timeout=30) == 0, launch.log()[-3000:]
    log = launch.log()
    assert "Traceback" not in log, log[-5000:]
    assert "Exception" not in log, log[-5000:]
    if group:
        recording = open_recording(tmp_path / "launch.mcap")
        assert recording.problem is None, recording.problem
        assert recording.metadata["middleware"] == "ROS 1" and recording.metadata["clock"] == "real"
        started = [r for r in recording.records if r["type"] == "state" and r["to"] == "idle"]
        assert started and started[0]["event"] == "start", "the launch's recorder heard the controller start"
        counters = [entry["detail"] for entry in recording.logs if entry["kind"] == "controller"]
        assert counters and counters[-1]["handovers"] >= 1, "the controller node's counters are recorded"
        [warned] = [e for e in recording.logs if e["kind"] == "rosout" and "lens" in e["detail"]["message"]]
        assert warned["level"] == "warning" and warned["sender"] == rospy.get_name().lstrip("/"), warned
        # The launch's recording re-runs the controller alone against its recorded inputs.
        again = CliRunner().invoke(cli, ["rerun", str(tmp_path / "launch.mcap")])
        assert again.exit_code == 0, f"{again.output}{again.exception!r}"
        assert "recorded over ROS 1 in real time: the controller alone re-ran against its" in again.output
        states = [r for r in recording.records if r["type"] == "state"]
        assert [r["event"] for r in states[:2]] == ["start", "aborted"], states
        assert f"same state changes as recorded ({len(states)})" in again.output, again.output


def test_a_scripted_run_over_ros_in_simulated_time_ends_without_a_traceback(
    ros: RosSession, tmp_path: Path
) -> None:
    """At the end of a script the launch stops every node; in simulated time the motivator ticks
    often, and a tick that came after its node's publishers were gone printed "the motivator's
    decision failed" with a traceback at every stop. A node now closes its part first."""
    command = [sys.executable, "-m", "cyborg.cli", "sim", "--ros", "--script", str(SCENARIO_D)]
    command += ["--speed", "max", "--db", str(tmp_path / "data")]  # lockstep: no load changes the script
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    output = done.stdout + done.stderr
    assert done.returncode == 0, output[-3000:]
    # (rospy's own "[WARN] Inbound TCP/IP connection failed" at a stop is the middleware's, not ours)
    assert "Traceback" not in output and "decision failed" not in output, output[-5000:]


def test_an_action_server_that_shut_down_answers_a_late_cancel_without_publishing(ros: RosSession) -> None:
    """The race behind the launch's tracebacks, made certain: rospy runs a cancel (the stopping
    controller's) on its thread after the server began to shut down; actionlib answers it with a
    status. Before, that was "publish() to a closed topic" and a traceback in the terminal."""
    node = ros.transport.node("cyborg_test_quiet_server")
    server: Any = node.action_server(
        "/cyborg_test_quiet_server/act", StateMachineAction, lambda handle: None, lambda handle: None
    )
    try:
        server.shutdown()
        server._server.publish_status()  # what actionlib's cancel callback and status timer do
        server._server.publish_result(None, None)
        server._server.publish_feedback(None, None)
    finally:
        node.shutdown()
