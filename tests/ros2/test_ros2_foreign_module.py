"""Our controller, over ROS 2, drives a module written in plain rclpy (foreign_module.py).

Runs in .venv-ros2 (tests/ros2/test_in_ros2_venv.py starts it). The controller, emotion system,
motivator, an idle placeholder and the speech gatekeeper are built in this process on the ROS 2
transport by the composition root (``build_robot``); the foreign module runs in a process of
its own and imports nothing of ours. What a user would notice: its speech reaches the speaker
(the gatekeeper's output) only in the states that grant it speech, and a module that ignores
the controller's cancel is handed over after the preempt timeout and silenced, as on ROS 1
(tests/ros/test_faults.py).
"""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from cyborg.app.config import load_config
from cyborg.app.robot import Robot, build_robot
from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.testing.wait import wait_until
from cyborg.transport import topics
from cyborg.transport.clock import Clock
from cyborg.transport.messages import String, SystemState
from tests.support.ros2 import isolate, ros2_session

HERE = Path(__file__).resolve().parent
CONFIG = HERE / "foreign.yaml"
GATEKEEPER = "cyborg_test_speech_gatekeeper"
PREEMPT_TIMEOUT = 1.0  # foreign.yaml's timeouts.preempt
PATIENCE = 20.0  # real seconds a wait may take on a loaded machine before the test fails


class Process:
    """A child process whose stdout lines are collected as they come."""

    def __init__(self, command: list[str]) -> None:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE, text=True, env=env)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line.rstrip("\n"))

    def said(self, text: str) -> bool:
        return any(text in line for line in self.lines)

    def wait_line(self, text: str, timeout: float = PATIENCE) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for line in self.lines:
                if text in line:
                    return line
            assert self.process.poll() is None, f"the process ended early: {self.lines}"
            time.sleep(0.02)
        raise AssertionError(f"no line with {text!r} within {timeout} s: {self.lines}")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(3)
            except subprocess.TimeoutExpired:  # a goal thread that never ends keeps it alive
                self.process.kill()
                self.process.wait(5)


@dataclass
class Heard:
    text: str
    sender: str
    at: float = field(default_factory=time.monotonic)


class World:
    """The robot of foreign.yaml in this process, and what an observer node hears."""

    def __init__(self, robot: Robot, clock: Clock) -> None:
        self.robot = robot
        self.clock = clock
        observer = robot.transport.node("cyborg_test_observer")
        self.changes: list[SystemState] = []
        self.spoken: list[Heard] = []  # /text_to_speech: what modules say
        self.said: list[Heard] = []  # the gatekeeper's output: what the speaker says
        observer.subscribe(topics.STATE_CHANGE, SystemState, lambda m, i: self.changes.append(m))
        observer.subscribe(
            "/text_to_speech", String, lambda m, i: self.spoken.append(Heard(m.data, i.sender))
        )
        observer.subscribe(
            "/cyborg_test_tts/say", String, lambda m, i: self.said.append(Heard(m.data, i.sender))
        )
        self.events = observer.publisher(topics.REGISTER_EVENT, String)

    @property
    def gatekeeper(self) -> Gatekeeper:
        keeper = self.robot.components[GATEKEEPER]
        assert isinstance(keeper, Gatekeeper)
        return keeper

    async def until(self, predicate: Callable[[], bool], what: str) -> None:
        assert await wait_until(predicate, self.clock, timeout=PATIENCE), f"timed out: {what}"

    async def in_state(self, state: str, event: str | None = None) -> SystemState:
        def reached() -> bool:
            return (
                bool(self.changes)
                and self.changes[-1].to_system_state == state
                and (event is None or self.changes[-1].event == event)
            )

        await self.until(reached, f"state {state} (changes: {self.changes[-3:]})")
        return self.changes[-1]

    async def start(self) -> None:
        self.robot.start()
        await self.in_state("idle")
        await self.until(lambda: self.events.subscriber_count() > 0, "the controller hears events")
        # As a node does before it starts: every topic connected to the foreign module's (DDS
        # discovery is done by then), so what it says first reaches the gatekeeper and the observer.
        missing = await asyncio.to_thread(self.robot.transport.wait_for_connections, PATIENCE)
        assert missing == [], missing

    def count(self, heard: list[Heard], prefix: str, sender: str, since: float = 0.0) -> int:
        return sum(1 for h in heard if h.text.startswith(prefix) and h.sender == sender and h.at >= since)


FOREIGN_NODE = "cyborg_foreign"


def wait_until_the_graph_lost(request: pytest.FixtureRequest, name: str) -> None:
    """Wait (up to PATIENCE) until no node ``name`` is left in the graph from an earlier test.

    A node that appears while the graph still holds a node of its name from a process just
    stopped shares the name with it, and the old one's removal takes the new one's publishers
    with it: the graph names their node _NODE_NAME_UNKNOWN_ for good, so their messages have no
    sender and the gatekeeper drops them all (seen under load in a full run: "speech passes"
    timed out). Our own nodes wait for this when they are dropped; a foreign process cannot.
    """
    transport = ros2_session(request.config).transport
    probe = transport._graph_probe()
    deadline = time.monotonic() + PATIENCE
    while any(node == name for node, _ in probe.get_node_names_and_namespaces()):
        assert time.monotonic() < deadline, f"node {name} still in the graph after {PATIENCE:g} s"
        time.sleep(0.02)


@pytest.fixture
def foreign(request: pytest.FixtureRequest) -> Iterator[Process]:
    isolate()
    wait_until_the_graph_lost(request, FOREIGN_NODE)
    module = Process([sys.executable, str(HERE / "foreign_module.py")])
    try:
        yield module
    finally:
        module.stop()


@pytest.fixture
def world(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[World]:
    session = ros2_session(request.config)
    robot = build_robot(load_config(CONFIG), session.transport, data_dir=tmp_path)
    try:
        yield World(robot, session.clock)
    finally:
        robot.close()
        for node in ("cyborg_test_observer",):
            leftover: Any = session.transport._nodes.get(node)
            if leftover is not None:
                leftover.shutdown()


def test_plain_rclpy_module_speaks_only_in_the_states_that_grant_it_speech(
    foreign: Process, world: World
) -> None:
    ready = foreign.wait_line("foreign module ready")
    assert ready.endswith("cyborg modules imported: []"), ready

    async def main() -> None:
        await world.start()
        # muted: the controller's goal runs the module, which speaks; the state grants it nothing
        world.events.publish(String("mute"))
        await world.in_state("muted", "mute")
        await world.until(lambda: world.count(world.spoken, "muted line", "cyborg_foreign") >= 3, "it speaks")
        world.events.publish(String("leave"))
        await world.in_state("idle", "leave")
        await world.until(lambda: foreign.said("goal muted canceled"), "the module acknowledges the cancel")
        # talking: the state grants it speech: the speaker says it, sent by the gatekeeper
        world.events.publish(String("talk"))
        await world.in_state("talking", "talk")
        await world.until(lambda: world.count(world.said, "talking line", GATEKEEPER) >= 3, "speech passes")
        world.events.publish(String("leave"))
        await world.in_state("idle", "leave")
        await world.until(lambda: foreign.said("goal talking canceled"), "the module acknowledges the cancel")

    world.clock.run(main())
    assert not [h for h in world.said if h.text.startswith("muted")], (
        "the gatekeeper let muted speech through"
    )
    assert {h.sender for h in world.said} == {GATEKEEPER}
    assert world.gatekeeper.stats.dropped_by_sender["cyborg_foreign"] >= 3


def test_plain_rclpy_module_ignoring_cancel_is_handed_over_and_silenced(
    foreign: Process, world: World
) -> None:
    foreign.wait_line("foreign module ready")

    async def main() -> None:
        await world.start()
        world.events.publish(String("stubborn"))
        await world.in_state("stubborn", "stubborn")
        await world.until(lambda: world.count(world.said, "stubborn line", GATEKEEPER) >= 2, "speech passes")
        sent = time.monotonic()
        world.events.publish(String("calm_down"))
        await world.in_state("idle", "calm_down")
        waited = time.monotonic() - sent
        # It accepted the cancel and went on: the controller waited its preempt timeout, no less.
        assert waited >= PREEMPT_TIMEOUT - 0.1, f"handover after {waited:.2f} s"
        assert not foreign.said("goal stubborn canceled")
        await world.until(
            lambda: world.gatekeeper.allowed == "cyborg_test_idle", "the gatekeeper reads idle's"
        )
        passed = world.gatekeeper.stats.passed  # all stubborn lines; it relays no more of them
        dropped = world.gatekeeper.stats.dropped_by_sender["cyborg_foreign"]
        mark = time.monotonic()
        await world.until(
            lambda: world.count(world.spoken, "stubborn line", "cyborg_foreign", since=mark) >= 3,
            "the stubborn module goes on speaking",
        )
        await world.until(
            lambda: world.gatekeeper.stats.dropped_by_sender["cyborg_foreign"] >= dropped + 3, "dropped"
        )
        assert world.gatekeeper.stats.passed == passed
        # what the speaker hears is what it relayed before (some may still have been on the way)
        await world.until(lambda: world.count(world.said, "stubborn line", GATEKEEPER) == passed, "in flight")
        await world.clock.sleep(0.3)
        assert world.count(world.said, "stubborn line", GATEKEEPER) == passed

    world.clock.run(main())
