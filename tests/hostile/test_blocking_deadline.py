"""Issue 31, item 4: a module that blocks the in-process robot's loop does not hold up a handover.

A student's state cleans up synchronously when it is preempted (a blocking serial close in a
``finally:``), so the module's goal holds the one event loop for seconds. The controller waits
for the acknowledgement at most ``timeouts.preempt``; before, that deadline ran out during the
block and acted only when the block ended (here 6 s). Now the loop watchdog stops the module's
blocking call once the controller's deadline has passed (by its grace of a second), and the
handover goes on then; the log names the module and what was stopped.

In-process, real time (the watchdog watches real time; virtual runs never block in real time).
"""

from __future__ import annotations

import asyncio
import logging
import time
from pathlib import Path
from typing import Any

import pytest

from cyborg.app.config import parse_config
from cyborg.app.registry import module_kinds
from cyborg.app.robot import build_robot
from cyborg.modules import ModuleKind, ModuleSettings, Node
from cyborg.modules.behaviour import BehaviourModule, GoalContext
from cyborg.transport import topics
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String, SystemState
from cyborg.transport.watchdog import GRACE, LoopWatchdog

BLOCK = 6.0
PREEMPT = 0.5

MACHINE = f"""
initial: idle
timeouts: {{connect: 2.0, preempt: {PREEMPT}}}
states:
  idle: {{action: cyborg_idle/idle, transitions: {{aborted: idle, go: slow}}}}
  slow: {{action: slow/work, transitions: {{aborted: idle, succeeded: idle, stop: idle}}}}
modules:
  cyborg_idle: {{kind: idle}}
  cyborg_slow: {{kind: closes_slowly}}
"""


class SlowCloser(BehaviourModule):
    def __init__(self, node: Node) -> None:
        super().__init__(node)
        self.serve("slow/work", self.work)

    async def work(self, ctx: GoalContext) -> None:
        try:
            await ctx.wait_forever()
        finally:
            time.sleep(BLOCK)  # the mistake: a synchronous close on the robot's loop


CLOSES_SLOWLY: ModuleKind[Any] = ModuleKind(ModuleSettings, lambda node, settings, context: SlowCloser(node))


def test_the_handover_keeps_its_deadline_while_a_module_blocks(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # An earlier robot of this process that was never closed left its watchdog's signal handler.
    stale_loop = asyncio.new_event_loop()
    stale = LoopWatchdog(stale_loop, deadline=lambda: None, stoppable=lambda module: False)
    stale.start()
    stale._stopped.set()
    stale_loop.close()
    config = parse_config(MACHINE, source="robot.yaml")
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    robot = build_robot(
        config, transport, data_dir=tmp_path, kinds=module_kinds({"closes_slowly": CLOSES_SLOWLY})
    )
    entered: dict[str, float] = {}

    def on_change(change: SystemState) -> None:
        if change.event != "start":  # the initial state is entered with 'start'
            entered.setdefault(change.to_system_state, time.monotonic())

    robot.controller.add_state_listener(on_change)
    events = transport.node("tester").publisher(topics.REGISTER_EVENT, String)

    async def until(state: str, limit: float) -> None:
        deadline = time.monotonic() + limit
        while state not in entered:
            assert time.monotonic() < deadline, (state, entered)
            await asyncio.sleep(0.02)

    async def main() -> float:
        robot.start()
        await asyncio.sleep(0.1)
        events.publish(String("go"))
        await until("slow", 10)
        await asyncio.sleep(0.2)  # the goal runs
        sent = time.monotonic()
        events.publish(String("stop"))
        await until("idle", 3 * BLOCK)
        took = entered["idle"] - sent
        await robot.controller.stop()
        robot.close()
        transport.shutdown()
        return took

    with caplog.at_level(logging.WARNING):
        try:
            took = clock.run(main())
        finally:
            clock.close()
    assert took < PREEMPT + GRACE + 1.5 < BLOCK, (
        f"the handover took {took:.2f} s (the module blocked {BLOCK} s)"
    )
    stopped = [
        r.getMessage()
        for r in caplog.records
        if "stopped" in r.getMessage() and "cyborg_slow" in r.getMessage()
    ]
    assert stopped, [r.getMessage() for r in caplog.records]
    assert "SlowCloser.work" in stopped[0] and "handover" in stopped[0], stopped[0]
