"""Closing the robot stops everything it started: no task, no timer, no open database is left.

The whole shipped robot runs in virtual time with a person talking to it, so modules are in the
middle of goals, the base may be driving and periodic work is armed when it is closed.
"""

from __future__ import annotations

import asyncio
import sqlite3
from pathlib import Path

from cyborg.app.config import load_config, packaged_config
from cyborg.app.robot import build_robot
from cyborg.modules.kind import Component
from cyborg.transport import topics
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String


def pending(loop: asyncio.AbstractEventLoop) -> tuple[list[str], list[str]]:
    """Names of the tasks not done and the timers not cancelled on ``loop``."""
    tasks = [
        t.get_name() for t in asyncio.all_tasks(loop) if not t.done() and t is not asyncio.current_task(loop)
    ]
    timers = [repr(h) for h in getattr(loop, "_scheduled", []) if not h.cancelled()]
    return tasks, timers


def test_closing_the_robot_leaves_no_task_or_timer(tmp_path: Path) -> None:
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    robot = build_robot(load_config(packaged_config("cyborg.yaml")), transport, data_dir=tmp_path)
    assert all(isinstance(c, Component) for c in robot.components.values())
    person = transport.node("person").publisher(topics.TEXT_FROM_SPEECH, String)

    async def run_then_close() -> tuple[list[str], list[str], list[str], list[str]]:
        robot.start()
        await clock.sleep(30.0)
        person.publish(String("Hello!"))
        await clock.sleep(20.0)
        person.publish(String("Where is the cafeteria?"))
        await clock.sleep(5.0)
        busy = pending(clock.loop)
        robot.close()
        for _ in range(5):  # let the cancelled tasks run their finally blocks
            await asyncio.sleep(0)
        return *busy, *pending(clock.loop)

    tasks_before, timers_before, tasks_after, timers_after = clock.run(run_then_close())
    assert tasks_before and timers_before, "the robot was working when it was closed"
    assert tasks_after == [], f"tasks left running: {tasks_after}"
    assert timers_after == [], f"timers left armed: {timers_after}"
    assert transport.node_names() == ["person"], "every node of the robot was shut down"
    clock.close()
    # The databases were closed, so another process can take them over at once.
    for name in ("controller.db", "navigation.db"):
        with sqlite3.connect(tmp_path / name, timeout=0.1) as conn:
            conn.execute("BEGIN EXCLUSIVE")
            conn.rollback()
