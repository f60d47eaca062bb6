"""The command tool over ROS (``cyborg ... --ros``) against real `cyborg node` processes.

The tool runs as a user would run it, a separate process on the session's roscore; the test
observes the controller's topics from this process.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from cyborg_controller.msg import EmotionalState  # type: ignore[import-not-found]
from std_msgs.msg import String  # type: ignore[import-not-found]

if TYPE_CHECKING:
    from conftest import Observers, Processes

FAULTS = Path(__file__).resolve().parent / "faults.yaml"


def tool(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "cyborg.interfaces.cli", *args, "--ros"],
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

    mark = changes.mark()
    result = tool("event", "work")
    assert result.returncode == 0, result.stderr
    assert "sent event work" in result.stdout
    changes.wait_state("working", event="work", after=mark)

    result = tool("status")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("idle --work--> working")
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
