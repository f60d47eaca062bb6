"""The command tool over ROS (``cyborg ... --ros``) against real `cyborg node` processes.

The tool runs as a user would run it, a separate process on the session's roscore; the test
observes the controller's topics from this process.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from cyborg_controller.msg import EmotionalState  # type: ignore[import-not-found]
from std_msgs.msg import String  # type: ignore[import-not-found]

from tests.support.ros import Observers, Processes

FAULTS = Path(__file__).resolve().parent / "faults.yaml"


def tool(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "cyborg.cli", *args, "--ros"],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )


def test_command_tool_drives_a_robot_of_ros_nodes(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    changes = observe.state_changes()
    emotions = observe.topic("/cyborg_controller/emotional_state", EmotionalState)
    heard = observe.topic("/text_from_speech", String)
    idle = processes.cyborg_node("cyborg_test_idle", FAULTS, tmp_path)
    worker = processes.cyborg_node("cyborg_test_worker", FAULTS, tmp_path)
    controller = processes.cyborg_node("cyborg_controller", FAULTS, tmp_path)
    processes.wait_ready(idle, worker, controller)
    changes.wait_state("idle", event="start")

    result = tool("event", "no_such_event")
    assert result.returncode == 0, result.stderr
    assert (
        "sent event no_such_event (not a transition of the current state: it will be dropped)"
        in result.stdout
    )

    mark = changes.mark()
    result = tool("event", "work")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "sent event work", "a transition of idle: no warning"
    changes.wait_state("working", event="work", after=mark)

    result = tool("status")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("idle --work--> working")
    assert "topicmanager initialized" not in result.stderr, "rospy's start-up chatter on every command"
    assert "emotion neutral" in result.stdout

    mark = emotions.mark()
    assert tool("emotion", "values", "-0.5", "0.6", "0.2").returncode == 0
    emotions.wait_for(
        lambda h: (
            abs(h.message.current_pleasure + 0.5) < 1e-6 and abs(h.message.current_arousal - 0.6) < 1e-6
        ),
        after=mark,
        what="PAD (-0.5, 0.6, 0.2)",
    )
    result = tool("status")
    assert "emotion angry (P -0.50 A +0.60 D +0.20)" in result.stdout, result.stdout

    assert tool("emotion", "set", "elated").returncode == 0
    emotions.wait_for(lambda h: h.message.to_emotional_state == "elated", after=mark, what="elated")

    heard.wait_connected(0)
    # /text_from_speech needs a listener in the graph: this process's recorder is one
    result = tool("say", "hello", "there")
    assert result.returncode == 0, result.stderr
    heard.wait_for(lambda h: h.message.data == "hello there" and h.sender.startswith("cyborg_tool_"))


def test_command_tool_without_a_master_explains_the_fix() -> None:
    env = {**os.environ, "ROS_MASTER_URI": "http://localhost:9"}
    result = tool("status", env=env)
    assert result.returncode != 0
    assert "no ROS master answers at http://localhost:9" in result.stderr
    assert "cyborg launch" in result.stderr


def test_a_controller_back_after_a_crash_resumes_its_emotion_and_a_fresh_start_is_neutral(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    """Issue: a restart came back angry with the emotion system silently off. Now only a
    controller started again without --fresh while the rest runs on resumes, and says so."""
    changes = observe.state_changes()
    emotions = observe.topic("/cyborg_controller/emotional_state", EmotionalState)
    idle = processes.cyborg_node("cyborg_test_idle", FAULTS, tmp_path)
    worker = processes.cyborg_node("cyborg_test_worker", FAULTS, tmp_path)
    first = processes.cyborg_node("cyborg_controller", FAULTS, tmp_path, "--fresh")
    processes.wait_ready(idle, worker, first)
    changes.wait_state("idle", event="start")
    status = tool("status").stdout
    assert "emotion neutral" in status and "emotion system on" in status, status

    mark = emotions.mark()
    assert tool("emotion", "set", "happy").returncode == 0  # the table's bracketed word
    emotions.wait_for(lambda h: h.message.to_emotional_state == "elated", after=mark, what="elated")
    assert tool("emotion", "off").returncode == 0
    deadline = time.monotonic() + 10
    while "emotion system OFF" not in (status := tool("status").stdout):
        assert time.monotonic() < deadline, status
    first.kill()

    back = processes.cyborg_node("cyborg_controller", FAULTS, tmp_path)  # as a respawn would
    processes.wait_ready(back)
    status = tool("status").stdout
    assert "emotion elated" in status and "emotion system OFF" in status, status
    ros_log = Path(os.environ["ROS_HOME"]) / "log" / "cyborg_controller.log"  # where rospy puts it
    assert "resumed the stored emotion elated" in ros_log.read_text(), ros_log.read_text()[-2000:]
    back.kill()

    fresh = processes.cyborg_node("cyborg_controller", FAULTS, tmp_path, "--fresh")
    processes.wait_ready(fresh)
    status = tool("status").stdout
    assert "emotion neutral" in status and "emotion system on" in status, status
