"""A scenario script over ROS: the ``cyborg_scenario`` node, and a run of it beside the robot's nodes.

``cyborg sim --ros --script FILE`` (``--ros2``) launches the robot's nodes (no API) plus the node
``cyborg_scenario``, which plays the script on the graph and writes the transcript as it goes
(:class:`~cyborg.sim.scenario.ScenarioDriver` on the middleware's transport), then stops them all.
"""

from __future__ import annotations

import contextlib
import json
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import click

from cyborg.app.config import LoadedConfig
from cyborg.app.context import BuildContext
from cyborg.app.parts import API, RECORDER, SCENARIO, build_part, part_names
from cyborg.errors import CyborgError
from cyborg.run.middleware import ROS1, Middleware
from cyborg.run.simtime import READY_TIMEOUT
from cyborg.run.supervisor import Launch
from cyborg.sim.transcript import TranscriptWriter
from cyborg.transport.base import Node
from cyborg.transport.clock import VirtualClock
from cyborg.transport.lockstep import LockstepClock
from cyborg.transport.messages import String

if TYPE_CHECKING:
    from cyborg.sim.script import Script

__all__ = ["SCENARIO", "ScenarioFiles", "ScenarioNode", "prepare_calendar", "run_scenario_ros"]


@dataclass
class ScenarioFiles:
    """What the ``cyborg_scenario`` node plays and where it writes."""

    script: Path
    transcript: Path | None = None


class ScenarioNode:
    """The ``cyborg_scenario`` node: a :class:`ScenarioDriver` writing its transcript as it goes."""

    def __init__(self, node: Node, files: ScenarioFiles) -> None:
        from cyborg.sim.scenario import ScenarioDriver
        from cyborg.sim.script import load_script

        self.node = node
        self.script = load_script(files.script)
        # With a transcript file the records go there as they come and none is kept (flat memory).
        self.driver = ScenarioDriver(node, self.script, keep_records=files.transcript is None)
        self._out: IO[str] | None = None
        self._writer: TranscriptWriter | None = None
        clock = node.clock
        if isinstance(clock, LockstepClock):  # named in the transcript: they may make a run differ
            clock.on_foreign.append(
                lambda names: self.driver.stream.emit("lockstep", not_lockstepped=list(names))
            )
        if files.transcript is not None:
            self._out = files.transcript.open("w", encoding="utf-8")
            self._writer = TranscriptWriter(self._out)
            self.driver.listeners.append(self._write)
        # Before reporting ready: wait until the robot listens, so the first steps (and the
        # script's starting emotion) reach it. (Our own RecordStream is one of the listeners to
        # what is "heard".)
        deadline = time.monotonic() + READY_TIMEOUT
        waits = [(self.driver.event, 1), (self.driver.say, 2)]
        if self.script.emotion:
            waits.append((self.driver.set_emotion, 1))
        for publisher, listeners in waits:
            while publisher.subscriber_count() < listeners and time.monotonic() < deadline:
                time.sleep(0.02)

    def _write(self, record: dict[str, Any]) -> None:
        assert self._out is not None and self._writer is not None
        if self._out.closed:
            return  # the script has ended: what still comes is after its end
        self._writer.write(record)

    def close(self) -> None:
        """Close the transcript (what was written stays)."""
        if self._out is not None and not self._out.closed:
            assert self._writer is not None
            self._writer.close()
            self._out.close()

    async def play(self) -> None:
        try:
            if self.script.emotion:
                self.driver.set_emotion.publish(String(self.script.emotion))
            await self.driver.run()
        finally:
            self.close()
        if self.driver.failures:
            from cyborg.errors import ScenarioFailed

            raise ScenarioFailed(self.driver.failures, source=self.script.source)


def prepare_calendar(config: LoadedConfig, data_dir: Path, map_path: Path | None, script: Script) -> None:
    """Put a script's calendar entries into the navigation module's database before its node starts."""
    if not script.calendar:
        return
    from cyborg.sim.scenario import add_calendar
    from cyborg.transport.embedded import EmbeddedTransport

    context = BuildContext(data_dir=data_dir, seed=0, map_path=map_path)
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    parts = []
    try:
        for name, raw in config.model.modules.items():
            if isinstance(raw, dict) and raw.get("kind") == "navigation":
                parts.append(build_part(name, config, transport, context))  # what the node will open
                break
        add_calendar(parts[0].calendar if parts else None, script)
    finally:
        for part in parts:
            part.close()
        transport.shutdown()
        clock.close()


def run_scenario_ros(
    config_path: Path,
    config: LoadedConfig,
    script_path: Path,
    *,
    transcript_path: Path | None,
    speed: float | None,
    data_dir: Path | None,
    map_path: Path | None,
    echo: bool = False,
    say: Callable[[str], None] = click.echo,
    middleware: Middleware = ROS1,
    record: Path | None = None,
) -> list[dict[str, Any]]:
    """Run a scenario on ``middleware``'s graph: the robot's nodes (no API) plus ``cyborg_scenario``;
    return the records. ``speed``: virtual time at that factor of real time; None: in lockstep.
    ``record``: the ``cyborg_recorder`` node records the run to this MCAP file (none otherwise: a
    node more per scripted ROS run)."""
    from cyborg.sim.scenario import check_script, script_start
    from cyborg.sim.script import load_script

    script = load_script(script_path)
    check_script(script, config)
    with contextlib.ExitStack() as stack:
        if data_dir is None:
            data_dir = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="cyborg-scenario-")))
        if transcript_path is None:
            transcript_path = data_dir / "transcript.jsonl"
        prepare_calendar(config, data_dir, map_path, script)
        parts = [name for name in part_names(config) if name not in (API, RECORDER)] + [SCENARIO]
        extra_args = {
            SCENARIO: ["--script", str(script_path.resolve()), "--transcript", str(transcript_path)]
        }
        if record is not None:
            parts.insert(1, RECORDER)
            extra_args[RECORDER] = ["--record", str(record.resolve())]
        robot = Launch(
            config_path,
            config,
            parts,
            data_dir,
            map_path,
            echo=echo,
            speed=speed,
            lockstep=speed is None,
            start=script_start(script),
            seed=script.seed,
            extra_args=extra_args,
            say=say,
            middleware=middleware,
        )
        try:
            robot.start_all()
            code = robot.wait(until=SCENARIO)
        finally:
            robot.stop_all()
        if code != 0:
            raise CyborgError(f"{SCENARIO} ended with exit code {code}; see its output above")
        return [json.loads(line) for line in transcript_path.read_text(encoding="utf-8").splitlines()]
