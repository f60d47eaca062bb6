"""Run a robot on a clock until stopped: the body of ``cyborg sim``."""

from __future__ import annotations

import asyncio
import logging
import signal
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

from cyborg.app.config import LoadedConfig
from cyborg.app.robot import Robot, build_robot
from cyborg.observe.recorder import Recorder, RecorderSettings, RunFacts
from cyborg.observe.records import RecordStream, to_ns
from cyborg.run.datadir import default_data_dir
from cyborg.run.tasks import watch_tasks
from cyborg.storage import lock_data_dir
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Transport
from cyborg.transport.clock import Clock, RealClock, VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.lockstep import LockstepClock
from cyborg.transport.messages import String, SystemState

log = logging.getLogger(__name__)


def make_clock(speed: float | str | None) -> Clock:
    """'real' -> real time; None -> virtual, as fast as possible; a number -> virtual at that speed."""
    if speed == "real":
        return RealClock()
    return VirtualClock(speed=None if speed is None else float(speed))


def run_sim(
    config: LoadedConfig,
    *,
    speed: float | str | None = "real",
    duration: float | None = None,
    echo: Callable[[str], None] = print,
    serve: Callable[[Transport, Robot], Awaitable[Callable[[], Awaitable[None]]]] | None = None,
    data_dir: Path | None = None,
    map_path: Path | None = None,
    record: RecorderSettings | None = None,
) -> None:
    """Run the robot of ``config`` until a signal (or ``duration``); ``record``: write it to MCAP."""
    with lock_data_dir(data_dir or default_data_dir()) as folder:
        _run(
            config,
            folder,
            speed=speed,
            duration=duration,
            echo=echo,
            serve=serve,
            map_path=map_path,
            record=record,
        )


def start_recorder(
    config: LoadedConfig, transport: Transport, robot: Robot, settings: RecorderSettings, clock: Clock
) -> Recorder:
    """A recorder of this robot from now on, on its own node and record stream."""
    node = transport.node("cyborg_recorder")
    stream = RecordStream(node)
    facts = RunFacts(
        start_ns=to_ns(clock.now()),
        clock=clock_kind(clock),
        config_name=Path(config.source).name or "config.yaml",
        config_text=config.text,
    )
    base = robot.base()
    return Recorder(node, stream, settings, facts, occupancy=base.map if base is not None else None)


def clock_kind(clock: Clock) -> str:
    """What a recording says of its clock: ``real``, ``virtual`` (as fast as possible), ``virtual xN``."""
    if not clock.is_virtual:
        return "real"
    if isinstance(clock, LockstepClock):
        return "lockstep"
    speed = getattr(clock, "speed", None)
    return "virtual" if speed is None else f"virtual x{speed:g}"


def _run(
    config: LoadedConfig,
    data_dir: Path,
    *,
    speed: float | str | None,
    duration: float | None,
    echo: Callable[[str], None],
    serve: Callable[[Transport, Robot], Awaitable[Callable[[], Awaitable[None]]]] | None,
    map_path: Path | None,
    record: RecorderSettings | None,
) -> None:
    clock = make_clock(speed)
    transport = EmbeddedTransport(clock)
    robot = build_robot(config, transport, data_dir=data_dir, map_path=map_path)
    recorder = start_recorder(config, transport, robot, record, clock) if record is not None else None
    if recorder is not None and recorder.path is not None:
        echo(f"recording to {recorder.path}")
    monitor = transport.node("cyborg_console")
    start = clock.monotonic()

    def stamp() -> str:
        return f"[{clock.monotonic() - start:8.1f}s]"

    def on_state(msg: SystemState, info: MessageInfo) -> None:
        echo(f"{stamp()} state  {msg.from_system_state or '-'} --{msg.event}--> {msg.to_system_state}")

    def on_say(msg: String, info: MessageInfo) -> None:
        echo(f"{stamp()} say    {info.sender}: {msg.data}")

    monitor.subscribe(topics.STATE_CHANGE, SystemState, on_state)
    monitor.subscribe(topics.TEXT_TO_SPEECH, String, on_say)

    async def main() -> None:
        stop_server = await serve(transport, robot) if serve is not None else None
        robot.start()
        tasks = watch_tasks(clock)  # a module leaking tasks is named (cyborg.run.tasks)
        signalled = _stop_on_signals(clock.loop)
        if duration is None:
            await signalled
        else:
            timer = asyncio.ensure_future(clock.sleep(duration))
            either: set[asyncio.Future[Any]] = {signalled, timer}
            await asyncio.wait(either, return_when=asyncio.FIRST_COMPLETED)
            timer.cancel()
        if signalled.done():
            echo(f"{stamp()} {signal.Signals(signalled.result()).name}: stopping")
        tasks.cancel()
        await robot.controller.stop()
        if stop_server is not None:
            await stop_server()
        if recorder is not None:
            recorder.close()
        robot.close()
        transport.shutdown()
        if signalled.done():
            echo("stopped")

    try:
        clock.run(main())
    finally:
        clock.close()


def _stop_on_signals(loop: asyncio.AbstractEventLoop) -> asyncio.Future[int]:
    """A future that SIGINT or SIGTERM (what a service manager sends) completes with the signal,
    so the robot stops as at the end of --duration. A second signal acts as usual, at once."""
    received: asyncio.Future[int] = loop.create_future()
    installed: list[int] = []

    def on_signal(number: int) -> None:
        for each in installed:
            loop.remove_signal_handler(each)
        if not received.done():
            received.set_result(number)

    for number in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(number, on_signal, number)
        except (ValueError, RuntimeError, NotImplementedError):  # not the main thread: no handlers
            continue
        installed.append(number)
    return received
