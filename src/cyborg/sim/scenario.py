"""Run a scenario script against a fresh simulated robot and write its transcript.

The robot starts in a fresh state (temporary databases unless a data folder is
given) on a virtual clock that starts at the script's ``start``. Steps fire at
their virtual times, or when a matching transcript record appears after the
previous step. Every record goes to the transcript, one JSON object a line.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import random
import tempfile
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import IO

from cyborg.app.config import LoadedConfig
from cyborg.app.robot import Robot, build_robot
from cyborg.errors import ConfigError, CyborgError
from cyborg.sim.records import Record, RecordStream
from cyborg.sim.script import CalendarEntry, Match, Script, Step, check_against
from cyborg.storage import lock_data_dir
from cyborg.transport import topics
from cyborg.transport.base import Node
from cyborg.transport.clock import DEFAULT_VIRTUAL_START, VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String

log = logging.getLogger(__name__)


class ScenarioDriver:
    """Plays a script's steps through ``node`` and passes the run's records to its listeners.

    Works on any transport: in ``cyborg sim --script`` beside an embedded robot, and as the ROS
    node ``cyborg_scenario`` beside a robot of ROS nodes. Times are the node's clock's loop
    time (``at: 300`` fires when it reads 300), so every process must share the clock's origin.
    ``records`` keeps every record unless ``keep_records`` is false (then memory stays flat
    however long the script runs: listeners, e.g. a transcript file, see each record once).
    """

    def __init__(self, node: Node, script: Script, *, origin: float = 0.0, keep_records: bool = True) -> None:
        self.node = node
        self.clock = node.clock
        self.script = script
        self.records: list[Record] = []
        self.keep_records = keep_records
        self.count = 0
        self.listeners: list[Callable[[Record], None]] = []
        self._waiting_for: Match | None = None  # the 'when' of the step being waited for
        self._matched = asyncio.Event()
        self.stream = RecordStream(node, origin=origin)
        self.stream.listeners.append(self._on_record)
        self.say = node.publisher(topics.TEXT_FROM_SPEECH, String)
        self.event = node.publisher(topics.REGISTER_EVENT, String)
        self.set_emotion = node.publisher(topics.SET_EMOTIONAL_STATE, String)

    def _on_record(self, record: Record) -> None:
        self.count += 1
        if self.keep_records:
            self.records.append(record)
        if self._waiting_for is not None and self._waiting_for.matches(record):
            self._matched.set()
        for listener in self.listeners:
            listener(record)

    def _watch(self, step: Step | None) -> None:
        """From now on, look for records matching ``step.when`` (if it waits for one)."""
        self._waiting_for = step.when if step is not None else None
        self._matched.clear()

    async def _wait_for(self) -> bool:
        """Wait until a record since the previous step's action matched; False at the end of the run."""
        if self._matched.is_set():
            return True
        remaining = self.script.until - self.clock.monotonic()
        if remaining <= 0:
            return False
        try:
            await asyncio.wait_for(self._matched.wait(), remaining)
        except TimeoutError:
            return False
        return True

    async def drive(self) -> None:
        """Play the steps in order (returns after the last one, or when one cannot happen)."""
        steps = self.script.steps
        self._watch(steps[0] if steps else None)
        for index, step in enumerate(steps):
            if step.at is not None:
                await self.clock.sleep(step.at - self.clock.monotonic())
            elif not await self._wait_for():
                log.warning("line %d: nothing matched %s before the end", step.line, step.when)
                return
            self._watch(None)
            await self.clock.sleep(step.delay)
            if step.say is not None:
                self.say.publish(String(step.say))
            elif step.event is not None:
                self.event.publish(String(step.event))
            elif step.emotion is not None:
                self.set_emotion.publish(String(step.emotion))
            self._watch(steps[index + 1] if index + 1 < len(steps) else None)

    async def run(self) -> list[Record]:
        """Play the script until its ``until`` time; return the records."""
        driver = asyncio.ensure_future(self.drive())
        try:
            await self.clock.sleep(self.script.until - self.clock.monotonic())
        finally:
            driver.cancel()
        return self.records


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
        keep_records: bool = True,
    ) -> None:
        check_script(script, config)
        self.script = script
        self.clock = VirtualClock(start=script_start(script), speed=speed)
        self.transport = EmbeddedTransport(self.clock)
        try:
            self.robot: Robot = build_robot(
                config, self.transport, data_dir=data_dir, rng=random.Random(script.seed), map_path=map_path
            )
            self.driver = ScenarioDriver(
                self.transport.node("cyborg_scenario"), script, keep_records=keep_records
            )
            self.records = self.driver.records
            self.listeners = self.driver.listeners
            self.stream = self.driver.stream
            self._prepare()
        except BaseException:
            self.transport.shutdown()  # a refused script leaves no half-started robot behind
            self.clock.close()
            raise

    def _prepare(self) -> None:
        if self.script.emotion:
            try:
                self.robot.emotion.set_named(self.script.emotion)
            except ValueError as exc:
                raise ConfigError(f"emotion: {exc}") from exc
        add_calendar(self.robot.calendar, self.script)

    async def _main(self) -> None:
        self.robot.start()
        await self.driver.run()
        await self.robot.controller.stop()

    def run(self) -> list[Record]:
        try:
            self.clock.run(self._main())
        finally:
            self.transport.shutdown()
            self.clock.close()
        return self.records


def check_script(script: Script, config: LoadedConfig) -> None:
    """Refuse events and emotions in ``script`` that the robot of ``config`` does not know."""
    events = {event for state in config.machine.states.values() for event in state.transitions}
    emotions = {"neutral", *config.model.emotion.prototypes, *config.model.emotion.usable_aliases()}
    check_against(script, events, emotions)


def add_calendar(calendar: Callable[[CalendarEntry], None] | None, script: Script) -> None:
    """Put the script's calendar entries into the navigation database; errors name the entry's line."""
    for number, entry in enumerate(script.calendar, start=1):
        if calendar is None:
            raise ConfigError(
                "calendar: this robot has no navigation module to keep a calendar; "
                "fix: remove 'calendar:' or add the navigation module"
            )
        try:
            calendar(entry)
        except CyborgError as exc:
            raise ConfigError(
                f"line {entry.line or '?'}: calendar entry {number}: {exc}", source=script.source
            ) from exc


def script_start(script: Script) -> datetime:
    """The virtual date-time a script starts at (UTC unless it says otherwise)."""
    start = script.start or DEFAULT_VIRTUAL_START
    return start if start.tzinfo is not None else start.replace(tzinfo=UTC)


def run_scenario(
    config: LoadedConfig,
    script: Script,
    *,
    transcript: IO[str] | None = None,
    data_dir: Path | None = None,
    speed: float | None = None,
    map_path: Path | None = None,
    keep_records: bool = True,
    on_record: Callable[[Record], None] | None = None,
) -> list[Record]:
    """Run ``script``; write each record to ``transcript`` as a JSON line; return the records.

    With ``keep_records=False`` the records go only to ``transcript`` and ``on_record`` as they
    happen and the returned list is empty, so a week-long script runs in flat memory.
    """
    with contextlib.ExitStack() as stack:
        scratch = stack.enter_context(tempfile.TemporaryDirectory(prefix="cyborg-scenario-"))
        if data_dir is not None:
            stack.enter_context(lock_data_dir(data_dir, "cyborg sim --script"))
        run = ScenarioRun(
            config,
            script,
            data_dir=data_dir or Path(scratch),
            speed=speed,
            map_path=map_path,
            keep_records=keep_records,
        )
        if transcript is not None:

            def write(record: Record) -> None:
                transcript.write(json.dumps(record) + "\n")

            run.listeners.append(write)
        if on_record is not None:
            run.listeners.append(on_record)
        return run.run()
