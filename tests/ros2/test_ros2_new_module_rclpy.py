"""The plain-rclpy variant that `cyborg new module` writes works beside our ROS 2 nodes.

Runs in .venv-ros2 (tests/ros2/test_in_ros2_venv.py starts it). As a student would run it:
this venv's python runs `rclpy_node.py` with no PYTHONPATH; our controller, idle, speech
gatekeeper and text-to-speech (the generated robot.yaml without its `greeter` entry, built in
this process) drive it, and its reply passes the gatekeeper. It imports nothing of ours and
prints no QoS warning about our topics.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner

from cyborg.app.config import load_config
from cyborg.app.robot import build_robot
from cyborg.cli import cli
from cyborg.testing.wait import wait_until
from cyborg.transport import topics
from cyborg.transport.messages import String, SystemState
from tests.support.ros2 import isolate, ros2_session

PATIENCE = 20.0  # real seconds a wait may take on a loaded machine before the test fails


class NodeProcess:
    """The generated rclpy node, its stdout and stderr (rclpy's log) collected line by line."""

    def __init__(self, script: Path) -> None:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        self.process = subprocess.Popen(
            [sys.executable, str(script)],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=env,
        )
        self.lines: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_line(self, text: str) -> None:
        deadline = time.monotonic() + PATIENCE
        while not any(text in line for line in self.lines):
            assert self.process.poll() is None, f"the node ended early: {self.lines}"
            assert time.monotonic() < deadline, f"no line with {text!r}: {self.lines}"
            time.sleep(0.02)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(5)


@pytest.fixture
def package(tmp_path: Path) -> Path:
    result = CliRunner().invoke(cli, ["new", "module", "greeter", "--dir", str(tmp_path)])
    assert result.exit_code == 0, result.output
    return tmp_path / "greeter"


@pytest.fixture
def rclpy_node(package: Path) -> Iterator[NodeProcess]:
    isolate()
    node = NodeProcess(package / "src" / "greeter" / "rclpy_node.py")
    try:
        yield node
    finally:
        node.stop()


def test_the_rclpy_variant_is_driven_by_our_controller_and_is_heard(
    package: Path, rclpy_node: NodeProcess, request: pytest.FixtureRequest, tmp_path: Path
) -> None:
    document = yaml.safe_load((package / "robot.yaml").read_text())
    del document["modules"]["greeter"]  # the rclpy node serves its state instead
    config = tmp_path / "robot.yaml"
    config.write_text(yaml.safe_dump(document))
    session = ros2_session(request.config)
    robot = build_robot(load_config(config), session.transport, data_dir=tmp_path / "db")
    observer = session.transport.node("cyborg_test_greeter_observer")
    changes: list[SystemState] = []
    said: list[tuple[str, str]] = []
    observer.subscribe(topics.STATE_CHANGE, SystemState, lambda m, i: changes.append(m))
    observer.subscribe("/cyborg_tts/say", String, lambda m, i: said.append((m.data, i.sender)))
    speech = observer.publisher("/text_from_speech", String)

    def state_is(state: str, event: str) -> bool:
        return bool(changes) and (changes[-1].to_system_state, changes[-1].event) == (state, event)

    async def until(predicate: Any, what: str) -> None:
        assert await wait_until(predicate, session.clock, timeout=PATIENCE), (
            f"timed out: {what} ({changes[-3:]})"
        )

    async def main() -> None:
        robot.start()
        await until(lambda: state_is("idle", "start"), "idle")
        missing = await session.clock.loop.run_in_executor(
            None, session.transport.wait_for_connections, PATIENCE
        )
        assert missing == [], missing
        # DDS discovery of the node's endpoints may still be under way: say it until it is heard
        for _ in range(int(PATIENCE)):
            speech.publish(String("Hello greeter, nice to meet you"))
            if await wait_until(lambda: state_is("greeter", "greeter_wanted"), session.clock, timeout=1.0):
                break
        await until(
            lambda: state_is("greeter", "greeter_wanted"), f"the greeter state; node: {rclpy_node.lines}"
        )
        await until(
            lambda: ("Hello! I am the greeter module.", "cyborg_speech_gatekeeper") in said, "the reply"
        )
        await until(lambda: state_is("idle", "succeeded"), "back to idle")

    try:
        rclpy_node.wait_line("greeter ready")
        session.clock.run(main())
    finally:
        robot.close()
        observer.shutdown()
    assert not [line for line in rclpy_node.lines if "QoS" in line or "Traceback" in line], rclpy_node.lines
