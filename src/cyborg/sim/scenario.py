"""Run a scenario script against a fresh simulated robot and write its transcript.

The robot starts in a fresh state (temporary databases unless a data folder is
given) on a virtual clock that starts at the script's ``start``. Steps fire at
their virtual times, or when a matching transcript record appears after the
previous step. Every record goes to the transcript, one JSON object a line.
"""

from __future__ import annotations

import asyncio
import json
import logging
import random
import tempfile
from collections.abc import Callable
from datetime import UTC
from pathlib import Path
from typing import IO

from cyborg.controller.config import LoadedConfig
from cyborg.errors import ConfigError
from cyborg.sim.records import Record, RecordStream
from cyborg.sim.robot import Robot, build_robot
from cyborg.sim.script import Script, Step
from cyborg.transport import topics
from cyborg.transport.clock import DEFAULT_VIRTUAL_START, VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String

log = logging.getLogger(__name__)


class ScenarioRun:
    """One run: the robot, its records, and the script driver."""

    def __init__(
        self,
        config: LoadedConfig,
        script: Script,
        *,
        data_dir: Path,
        speed: float | None = None,
        map_path: Path | None = None,
    ) -> None:
        start = script.start or DEFAULT_VIRTUAL_START
        if start.tzinfo is None:
            start = start.replace(tzinfo=UTC)
        self.script = script
        self.clock = VirtualClock(start=start, speed=speed)
        self.transport = EmbeddedTransport(self.clock)
        self.robot: Robot = build_robot(
            config, self.transport, data_dir=data_dir, rng=random.Random(script.seed), map_path=map_path
        )
        self.records: list[Record] = []
        self.listeners: list[Callable[[Record], None]] = []
        self._new_record = asyncio.Event()
        node = self.transport.node("cyborg_scenario")
        self.stream = RecordStream(node, origin=0.0)
        self.stream.listeners.append(self._on_record)
        self._say = node.publisher(topics.TEXT_FROM_SPEECH, String)
        self._event = node.publisher(topics.REGISTER_EVENT, String)
        self._set_emotion = node.publisher(topics.SET_EMOTIONAL_STATE, String)
        self._prepare()

    def _prepare(self) -> None:
        if self.script.emotion:
            try:
                self.robot.emotion.set_named(self.script.emotion)
            except ValueError as exc:
                raise ConfigError(f"emotion: {exc}") from exc
        for entry in self.script.calendar:
            if self.robot.calendar is None:
                raise ConfigError(
                    "calendar: this robot has no navigation module to keep a calendar; fix: remove 'calendar:' or add the navigation module"
                )
            self.robot.calendar(entry)

    def _on_record(self, record: Record) -> None:
        self.records.append(record)
        self._new_record.set()
        for listener in self.listeners:
            listener(record)

    async def _wait_for(self, step: Step, after: int) -> bool:
        """Wait until a record after index ``after`` matches ``step.when``; False at the end of the run."""
        assert step.when is not None
        while True:
            if any(step.when.matches(record) for record in self.records[after:]):
                return True
            after = len(self.records)
            remaining = self.script.until - self.clock.monotonic()
            if remaining <= 0:
                return False
            self._new_record.clear()
            try:
                await asyncio.wait_for(self._new_record.wait(), remaining)
            except TimeoutError:
                return False

    async def _drive(self) -> None:
        mark = 0
        for step in self.script.steps:
            if step.at is not None:
                await self.clock.sleep(step.at - self.clock.monotonic())
            elif not await self._wait_for(step, mark):
                log.warning("line %d: nothing matched %s before the end", step.line, step.when)
                return
            await self.clock.sleep(step.delay)
            if step.say is not None:
                self._say.publish(String(step.say))
            elif step.event is not None:
                self._event.publish(String(step.event))
            elif step.emotion is not None:
                self._set_emotion.publish(String(step.emotion))
            mark = len(self.records)

    async def _main(self) -> None:
        self.robot.start()
        driver = asyncio.ensure_future(self._drive())
        await self.clock.sleep(self.script.until)
        driver.cancel()
        await self.robot.controller.stop()

    def run(self) -> list[Record]:
        try:
            self.clock.run(self._main())
        finally:
            self.transport.shutdown()
            self.clock.close()
        return self.records


def run_scenario(
    config: LoadedConfig,
    script: Script,
    *,
    transcript: IO[str] | None = None,
    data_dir: Path | None = None,
    speed: float | None = None,
    map_path: Path | None = None,
) -> list[Record]:
    """Run ``script``; write each record to ``transcript`` as a JSON line; return the records."""
    with tempfile.TemporaryDirectory(prefix="cyborg-scenario-") as scratch:
        run = ScenarioRun(config, script, data_dir=data_dir or Path(scratch), speed=speed, map_path=map_path)
        if transcript is not None:

            def write(record: Record) -> None:
                transcript.write(json.dumps(record) + "\n")

            run.listeners.append(write)
        return run.run()
