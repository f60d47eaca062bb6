"""Run a scenario script against a fresh simulated robot and write its transcript.

The robot starts in a fresh state (temporary databases unless a data folder is
given) on a virtual clock that starts at the script's ``start``. Steps fire at
their virtual times, or when a matching transcript record appears after the
previous step. Every record goes to the transcript, one JSON object a line.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
import tempfile
from collections import deque
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import IO

from cyborg.app.config import LoadedConfig
from cyborg.app.registry import KindRegistry
from cyborg.app.robot import Robot, build_robot
from cyborg.errors import ConfigError, CyborgError, ScenarioFailed
from cyborg.observe.recorder import Recorder, RecorderSettings, RunFacts
from cyborg.observe.records import NS_PER_S, Record, RecordStream, to_ns
from cyborg.sim.script import CalendarEntry, Match, Script, Step, check_against
from cyborg.sim.transcript import TranscriptWriter
from cyborg.sim.witness import Witness
from cyborg.storage import lock_data_dir
from cyborg.transport import topics
from cyborg.transport.base import Node
from cyborg.transport.clock import DEFAULT_VIRTUAL_START, VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String

log = logging.getLogger(__name__)

RECENT_KEPT = 200
"""Records kept while a step waits, to say what came instead of what it waited for."""
NOTES_TOLD = 5
INPUT_GRID_NS = 1000
"""A script's inputs happen on whole microseconds since the run started (see ``_on_the_grid``)."""
ON_THE_GRID_NS = 0.001
"""A time this close to a whole microsecond is on it (a float's last bits, not a later moment)."""
"""What dropped or broke in a failed step's window: the last this many notes are told."""


def _brief(record: Record) -> str:
    t = f"t={float(record['t']):g}"  # type: ignore[arg-type]
    kind = record.get("type")
    if kind == "state":
        return f"{t} {record.get('from')} --{record.get('event')}--> {record.get('to')}"
    if kind in ("say", "heard"):
        return f"{t} {kind} {record.get('text')!r}"
    if kind == "emotion":
        return f"{t} emotion {record.get('emotion')}"
    rest = ", ".join(f"{k}: {v}" for k, v in record.items() if k not in ("t", "t_ns", "type"))
    return f"{t} {kind} {{{rest}}}"


class ScenarioRecords(list[Record]):
    """A run's records (empty if it kept none), and its :attr:`summary`."""

    def __init__(self, records: list[Record], summary: str, recordings: list[Path] | None = None) -> None:
        super().__init__(records)
        self.summary = summary
        """E.g. "6 of 6 expectations met"."""
        self.recordings = recordings or []
        """The MCAP files the run was recorded to."""


class ScenarioDriver:
    """Plays a script's steps through ``node`` and passes the run's records to its listeners.

    Works on any transport: in ``cyborg sim --script`` beside an embedded robot, and as the ROS
    node ``cyborg_scenario`` beside a robot of ROS nodes. Times are the node's clock's loop
    time (``at: 300`` fires when it reads 300), so every process must share the clock's origin.
    ``records`` keeps every record unless ``keep_records`` is false (then memory stays flat
    however long the script runs: listeners, e.g. a transcript file, see each record once).

    A step is armed (it sees the records from then on) when the previous one is done: at the
    start for the first step, right after the matching record for an ``expect`` (so the next
    step sees the records that follow it in the same loop turn), when its action was taken for
    an action step, and at the end of its window for an ``expect_not``.
    """

    def __init__(self, node: Node, script: Script, *, origin: float = 0.0, keep_records: bool = True) -> None:
        self.node = node
        self.clock = node.clock
        self.script = script
        self.records: list[Record] = []
        self.keep_records = keep_records
        self.count = 0
        self.listeners: list[Callable[[Record], None]] = []
        self.expectations = sum(1 for s in script.steps if s.expect is not None or s.expect_not is not None)
        """The script's ``expect`` and ``expect_not`` steps."""
        self.met = 0
        """Expectations met so far."""
        self._armed: int | None = None  # the index of the step that sees the records
        self._armed_at = self.clock.monotonic()
        self._waiting_for: Match | None = None  # its 'when', 'expect' or 'expect_not'
        self._hit: Record | None = None  # the record that matched it
        self._progress = asyncio.Event()
        self._since: deque[Record] = deque(maxlen=RECENT_KEPT)  # records since that step was armed
        self._step: tuple[int, Step, float] | None = None  # the step under way, and since when
        self.failures: list[str] = []
        """Expectations that failed and ``when`` steps that never fired, one line each."""
        self.stream = RecordStream(node, origin=origin)
        self.witness = Witness(node, origin=self.stream.origin)
        self.stream.listeners.append(self._on_record)
        self.say = node.publisher(topics.TEXT_FROM_SPEECH, String)
        self.event = node.publisher(topics.REGISTER_EVENT, String)
        self.set_emotion = node.publisher(topics.SET_EMOTIONAL_STATE, String)
        self._arm(0)

    def summary(self) -> str:
        """E.g. "6 of 6 expectations met"."""
        return f"{self.met} of {self.expectations} expectation{'' if self.expectations == 1 else 's'} met"

    def _on_record(self, record: Record) -> None:
        self.count += 1
        if self.keep_records:
            self.records.append(record)
        self.witness.on_record(record)
        if self._waiting_for is not None and self._armed is not None:
            self._since.append(record)
            if self._hit is None and self._waiting_for.matches(record):
                self._hit = record
                if self.script.steps[self._armed].expect is not None:
                    self.met += 1
                    self._arm(self._armed + 1)  # the records after this one are the next step's
                self._progress.set()
        for listener in self.listeners:
            listener(record)

    def _arm(self, index: int | None) -> None:
        """From now on, step ``index`` sees the records (None: no step does)."""
        steps = self.script.steps
        step = steps[index] if index is not None and index < len(steps) else None
        self._armed = index if step is not None else None
        self._armed_at = self.clock.monotonic()
        self._waiting_for = (step.when or step.expect or step.expect_not) if step is not None else None
        self._hit = None
        self._since.clear()

    def _done(self, index: int) -> bool:
        """Step ``index`` is met: a later step is armed, or it is armed and its record came."""
        return self._armed is None or self._armed > index or (self._armed == index and self._hit is not None)

    async def _wait_for(self, index: int, within: float | None = None) -> bool:
        """Wait until step ``index``'s record came; False at the end of the run (or after ``within``
        seconds from when the step was armed)."""
        end = self.script.until if within is None else min(self.script.until, self._armed_at + within)
        while not self._done(index):
            remaining = end - self.clock.monotonic()
            if remaining <= 0:
                return False
            self._progress.clear()
            try:
                await asyncio.wait_for(self._progress.wait(), remaining)
            except TimeoutError:
                return self._done(index)
        return True

    async def drive(self) -> None:
        """Play the steps in order (returns after the last one, or when one cannot happen)."""
        steps = self.script.steps
        for index, step in enumerate(steps):
            self._step = (index, step, self._armed_at if self._armed == index else self.clock.monotonic())
            if step.expect is not None:
                if not await self._wait_for(index, step.within):
                    self._fail_step()
                    return
                continue
            if step.expect_not is not None:
                if await self._wait_for(index, step.within):
                    self._fail_step()
                    return
                self.met += 1
                self._arm(index + 1)
                continue
            if step.at is not None:
                await self._until(step.at)
            elif not await self._wait_for(index):
                self._fail_step()
                return
            self._step = None
            self._arm(None)
            await self.clock.sleep(step.delay)
            await self._on_the_grid()
            if step.say is not None:
                self.say.publish(String(step.say))
            elif step.event is not None:
                self.event.publish(String(step.event))
            elif step.emotion is not None:
                self.set_emotion.publish(String(step.emotion))
            self._arm(index + 1)

    async def _until(self, when: float) -> None:
        """Sleep until the loop's time is ``when`` exactly (a deadline, not a duration: a re-run's
        input lands on the very float its recording names)."""
        loop = self.clock.loop
        if loop.time() >= when:
            await asyncio.sleep(0)
            return
        woken: asyncio.Future[None] = loop.create_future()

        def wake() -> None:
            if not woken.done():
                woken.set_result(None)

        handle = loop.call_at(when, wake)
        try:
            await woken
        finally:
            handle.cancel()

    async def _on_the_grid(self) -> None:
        """Wait (at most a microsecond) until the loop's time is a whole microsecond since the run
        started: an input then happens at the very time its record names (integer nanoseconds),
        and a re-run that plays it there follows the same path. (A deadline closer than the
        loop's resolution, a nanosecond, would fire at once, off the grid: the next one is taken.)"""
        now = self.clock.monotonic() - self.stream.origin
        nearest = round(now * NS_PER_S)
        if nearest % INPUT_GRID_NS == 0 and abs(now * NS_PER_S - nearest) < ON_THE_GRID_NS:
            return  # on it, but for the last bit of a float (``at: 60`` after a long jump)
        t_ns = -(-nearest // INPUT_GRID_NS) * INPUT_GRID_NS
        while t_ns / NS_PER_S - now < 2e-9:
            t_ns += INPUT_GRID_NS
        await self._until(self.stream.origin + t_ns / NS_PER_S)

    def _fail_step(self) -> None:
        """The step being waited for did not come: record what it waited for and what came instead."""
        if self._step is None or self.failures:
            return
        index, step, armed = self._step
        where = f"line {step.line or '?'}: step {index + 1}"
        limit = f"within {step.within:g} s" if step.within is not None else "before the end"
        if step.expect is not None:
            problem = (
                f"{where} expected {step.expect.describe()} {limit} (from t={armed:.1f} s); "
                f"instead: {self._instead(step.expect, armed)}"
            )
        elif step.expect_not is not None:
            if self._hit is None:
                return  # the end came first: nothing matching came in its window
            problem = (
                f"{where} expected no {step.expect_not.describe()} {limit} (from t={armed:.1f} s); "
                f"instead: {_brief(self._hit)}"
            )
        elif step.when is not None:
            problem = (
                f"{where} waited for {step.when.describe()}, which never came before the end "
                f"(until: {self.script.until:g} s); instead: {self._instead(step.when, armed)}"
            )
        else:
            return  # an 'at' step whose time is after the end: nothing was promised
        log.info("%s", problem)
        self.failures.append(problem)

    def _instead(self, match: Match, armed: float) -> str:
        """What came instead of ``match``: the last records of its type since the step was armed,
        and what the witness saw drop or break in that window."""
        same = [record for record in self._since if record.get("type") == match.type]
        came = "; ".join(_brief(record) for record in same[-3:]) if same else f"no {match.type} record at all"
        notes = self.witness.since(to_ns(armed - self.stream.origin))
        if notes:
            told = "; ".join(f"t={note.t:g} {note.text}" for note in notes[-NOTES_TOLD:])
            return f"{came}; in that window: {told}"
        if match.type == "state":  # nothing dropped or broke: what moves the robot on its own, and why not
            decisions = [record for record in self._since if record.get("type") == "motivator"]
            if decisions:
                last = decisions[-1]
                came += f" (the motivator's last decision, at t={float(last['t']):g}: {last.get('reason')})"  # type: ignore[arg-type]
            else:
                came += " (no decision of the motivator came)"
        return came

    async def run(self) -> list[Record]:
        """Play the script until its ``until`` time, or until a step fails; return the records."""
        driver = asyncio.ensure_future(self.drive())
        end = asyncio.ensure_future(self.clock.sleep(self.script.until - self.clock.monotonic()))
        try:
            await asyncio.wait({driver, end}, return_when=asyncio.FIRST_COMPLETED)
            if not driver.done():
                self._end_of_run()  # the end came while a step still waited
            elif not self.failures and not end.done():
                await end  # the steps are done; the run goes on to its end
        finally:
            driver.cancel()
            end.cancel()
        return self.records

    def _end_of_run(self) -> None:
        """The end came while a step waited: an ``expect_not`` whose window reached it is met,
        anything else failed."""
        if self._step is not None and self._step[1].expect_not is not None and self._hit is None:
            self.met += 1
            self._step = None
            return
        self._fail_step()


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
        kinds: KindRegistry | None = None,
        record: RecorderSettings | None = None,
        script_text: str | None = None,
    ) -> None:
        check_script(script, config)
        self.script = script
        self.interrupted = False
        """True when Ctrl-C ended the run (see :meth:`run`)."""
        self._driving: asyncio.Future[list[Record]] | None = None
        self.clock = VirtualClock(start=script_start(script), speed=speed)
        self.transport = EmbeddedTransport(self.clock)
        try:
            self.robot: Robot = build_robot(
                config,
                self.transport,
                data_dir=data_dir,
                seed=script.seed,
                map_path=map_path,
                kinds=kinds,
            )
            self.driver = ScenarioDriver(
                self.transport.node("cyborg_scenario"), script, keep_records=keep_records
            )
            self.records = self.driver.records
            self.listeners = self.driver.listeners
            self.stream = self.driver.stream
            self.recorder: Recorder | None = None
            """Writes the run to MCAP (with ``record``)."""
            if record is not None:
                self.recorder = self._recorder(config, record, speed, script_text)
            self._prepare()
        except BaseException:
            self.transport.shutdown()  # a refused script leaves no half-started robot behind
            self.clock.close()
            raise

    @property
    def summary(self) -> str:
        """E.g. "6 of 6 expectations met" (after :meth:`run`)."""
        return self.driver.summary()

    def _recorder(
        self, config: LoadedConfig, record: RecorderSettings, speed: float | None, script_text: str | None
    ) -> Recorder:
        base = self.robot.base()
        facts = RunFacts(
            start_ns=to_ns(self.clock.start_epoch),
            clock="virtual" if speed is None else f"virtual x{speed:g}",
            seed=self.script.seed,
            config_name=Path(config.source).name or "config.yaml",
            config_text=config.text,
            script_name=Path(self.script.source).name or "script.yaml",
            script_text=script_text if script_text is not None else _script_text(self.script),
        )
        return Recorder(
            self.transport.node("cyborg_recorder"),
            self.driver.stream,
            record,
            facts,
            occupancy=base.map if base is not None else None,
        )

    def _prepare(self) -> None:
        if self.script.emotion:
            try:
                self.robot.emotion.set_named(self.script.emotion)
            except ValueError as exc:
                raise ConfigError(f"emotion: {exc}") from exc
        add_calendar(self.robot.calendar, self.script)

    async def _main(self) -> None:
        self.robot.start()
        self._driving = asyncio.ensure_future(self.driver.run())
        try:
            await self._driving
        except asyncio.CancelledError:
            if not self.interrupted:
                raise
        await self.robot.controller.stop()

    def _interrupt(self) -> None:
        self.interrupted = True
        self.clock.loop.remove_signal_handler(signal.SIGINT)  # a second Ctrl-C stops at once
        if self._driving is not None:
            self._driving.cancel()

    def run(self, *, stop_on_interrupt: bool = False) -> ScenarioRecords:
        """Run the script to its end (the records, with the summary of its expectations); :class:`ScenarioFailed` if an expectation failed or a ``when``
        never fired (the transcript holds every record up to the end either way).

        ``stop_on_interrupt`` (the command line): Ctrl-C ends the script where it is, the robot
        stops and closes as at the end, then KeyboardInterrupt is raised (no half-run tasks left).
        """
        loop = self.clock.loop
        handled = False
        if stop_on_interrupt:
            with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):  # not the main thread
                loop.add_signal_handler(signal.SIGINT, self._interrupt)
                handled = True
        try:
            self.clock.run(self._main())
        finally:
            if handled and not loop.is_closed():
                loop.remove_signal_handler(signal.SIGINT)
            if self.recorder is not None:
                self.recorder.close()
            self.robot.close()
            self.transport.shutdown()
            self.clock.close()
        if self.interrupted:
            raise KeyboardInterrupt
        if self.driver.failures:
            raise ScenarioFailed(self.driver.failures, source=self.script.source)
        recordings = list(self.recorder.files) if self.recorder is not None else []
        return ScenarioRecords(self.records, self.summary, recordings)


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


def _script_text(script: Script) -> str:
    """The script's file, as it was read (else the script written out as YAML)."""
    try:
        return Path(script.source).read_text(encoding="utf-8")
    except (OSError, ValueError):
        import yaml

        return yaml.safe_dump(script.model_dump(mode="json", exclude_none=True), sort_keys=False)


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
    kinds: KindRegistry | None = None,
    stop_on_interrupt: bool = False,
    record: RecorderSettings | None = None,
) -> ScenarioRecords:
    """Run ``script``; write each record to ``transcript`` as a JSON line; return the records
    (and the ``summary`` of its expectations: "6 of 6 expectations met").

    ``kinds`` defaults to every installed module kind. With ``keep_records=False`` the records go
    only to ``transcript`` and ``on_record`` as they happen and the returned list is empty, so a
    week-long script runs in flat memory. ``stop_on_interrupt``: see :meth:`ScenarioRun.run`.
    ``record``: write the run to MCAP as it happens (:mod:`cyborg.observe.recorder`).
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
            kinds=kinds,
            record=record,
        )
        if transcript is not None:
            writer = TranscriptWriter(transcript)
            stack.callback(writer.close)
            run.listeners.append(writer.write)
        if on_record is not None:
            run.listeners.append(on_record)
        return run.run(stop_on_interrupt=stop_on_interrupt)
