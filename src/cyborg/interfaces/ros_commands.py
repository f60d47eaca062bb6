"""``cyborg node NAME``: one part of the robot as a ROS 1 node, and what launches share with it.

Needs ROS 1 (scripts/install-ros) and a master (``roscore``; ``cyborg launch`` starts one when
none answers at ``ROS_MASTER_URI``).

Simulated time (``--speed N``): every node runs a :class:`VirtualClock` at speed N from one
origin, so their virtual times agree. ``cyborg node --epoch T`` gives the origin as a wall-clock
time; ``cyborg launch --speed N`` sets ``/use_sim_time``, starts the nodes with ``--epoch
param:NS`` and, once every node is built and waiting, fixes the origin in the parameter
``NS/epoch`` (nodes take seconds to start, so a time chosen in advance would be missed or
wasted). The simulated base (``rosarnl_node``; the controller when no base runs) publishes
``/clock`` from its clock ~10 times a real second, so ``rostopic``, ``rosbag`` and actionlib's
timers follow the simulated time too.

``cyborg sim --ros --script FILE`` runs a scenario script over ROS: the robot's nodes plus the
node ``cyborg_scenario``, which plays the script and records the transcript
(:class:`ScenarioDriver` on the ROS transport).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import os
import random
import signal
import sys
import time
import xmlrpc.client
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

import click

from cyborg.app.config import LoadedConfig
from cyborg.app.memory import freeze_built
from cyborg.app.parts import API, CONTROLLER, NodeContext, Part, build_part
from cyborg.errors import CyborgError
from cyborg.interfaces.access import Access, announcement
from cyborg.transport import topics
from cyborg.transport.base import Node, Publisher
from cyborg.transport.clock import DEFAULT_VIRTUAL_START, Clock, RealClock, VirtualClock
from cyborg.transport.messages import Clock as ClockMessage
from cyborg.transport.messages import String

SCENARIO = "cyborg_scenario"
CLOCK_TOPIC = "/clock"
CLOCK_RATE = 10.0  # /clock messages per real second
USE_SIM_TIME = "/use_sim_time"
SIM_PARAMS = "/cyborg_sim"  # a launch's shared-time parameters live under SIM_PARAMS/<run id>
EPOCH_PARAM_PREFIX = "param:"
EPOCH_MARGIN = 0.5  # real seconds between the last node being ready and virtual time starting
READY_TIMEOUT = 120.0  # real seconds a launch waits for its nodes to be ready


def master_uri() -> str:
    return os.environ.get("ROS_MASTER_URI", "http://localhost:11311")


def master_running(uri: str | None = None) -> bool:
    try:
        xmlrpc.client.ServerProxy(uri or master_uri()).getSystemState("/cyborg")
    except (OSError, xmlrpc.client.Error):
        return False
    return True


def require_ros() -> None:
    try:
        import cyborg.transport.ros  # noqa: F401  (imports rospy and actionlib)
    except ImportError:
        raise CyborgError(
            "ROS 1 is not available in this environment; fix: run scripts/install-ros, then "
            "`source .venv/bin/activate`"
        ) from None


class Master:
    """The parameter server of ``ROS_MASTER_URI``, through plain XML-RPC (no ROS node needed)."""

    def __init__(self, uri: str | None = None, caller: str = "/cyborg_launch") -> None:
        self.uri = uri or master_uri()
        self.caller = caller
        self._proxy = xmlrpc.client.ServerProxy(self.uri)

    def get(self, key: str, default: Any = None) -> Any:
        answer: Any = self._proxy.getParam(self.caller, key)
        return answer[2] if answer[0] == 1 else default

    def has(self, key: str) -> bool:
        answer: Any = self._proxy.hasParam(self.caller, key)
        return bool(answer[0] == 1 and answer[2])

    def set(self, key: str, value: Any) -> None:
        self._proxy.setParam(self.caller, key, value)

    def delete(self, key: str) -> None:
        with contextlib.suppress(OSError, xmlrpc.client.Error):
            self._proxy.deleteParam(self.caller, key)


# --- time options of a node -------------------------------------------------------------


@dataclass(frozen=True)
class SimTime:
    """How a node keeps time: real time, or virtual time at ``speed`` from a shared origin.

    ``epoch``: the wall-clock time (Unix seconds) at which virtual time reads ``start``; or
    ``param:NS``, to wait for the launch to set ``NS/epoch`` once every node is ready; or
    None: the moment the node starts.
    """

    speed: float | None = None
    epoch: float | str | None = None
    start: datetime = DEFAULT_VIRTUAL_START

    @property
    def virtual(self) -> bool:
        return self.speed is not None

    @property
    def epoch_params(self) -> str | None:
        if isinstance(self.epoch, str) and self.epoch.startswith(EPOCH_PARAM_PREFIX):
            return self.epoch[len(EPOCH_PARAM_PREFIX) :].rstrip("/")
        return None

    def make_clock(self) -> Clock:
        if self.speed is None:
            if self.epoch is not None:
                raise CyborgError("--epoch goes with --speed: real time needs no shared origin")
            return RealClock()
        if self.epoch_params is not None:
            origin = math.inf  # stands still until the launch fixes the origin
        elif self.epoch is None:
            origin = time.time()
        else:
            origin = float(self.epoch)
        return VirtualClock(self.start, self.speed, real_origin=origin)


def parse_epoch(value: str | None) -> float | str | None:
    """``--epoch``: Unix seconds (``1795424400.5``) or ``param:/cyborg_sim/RUN``."""
    if value is None or value.startswith(EPOCH_PARAM_PREFIX):
        return value
    try:
        return float(value)
    except ValueError:
        raise click.BadParameter(
            f"{value!r} is neither a time in Unix seconds (e.g. {time.time():.1f}) nor param:NAMESPACE"
        ) from None


def parse_start(value: str | None) -> datetime:
    """``--start``: an ISO date-time (UTC unless it says otherwise); default the simulator's usual start."""
    if value is None:
        return DEFAULT_VIRTUAL_START
    try:
        moment = datetime.fromisoformat(value)
    except ValueError:
        raise click.BadParameter(f"{value!r} is not an ISO date-time, e.g. 2026-11-23T15:29:00") from None
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


async def publish_clock(publisher: Publisher[ClockMessage], clock: VirtualClock) -> None:
    """Publish ``clock``'s time on /clock about CLOCK_RATE times a real second, for ever."""
    assert clock.speed is not None
    step = clock.speed / CLOCK_RATE
    while True:
        publisher.publish(ClockMessage(clock.now()))
        await clock.sleep(step)


def is_simulated_base(config: LoadedConfig, name: str) -> bool:
    raw = config.model.modules.get(name)
    return isinstance(raw, dict) and raw.get("kind") == "simulated_base"


def clock_owner_of(config: LoadedConfig, parts: Sequence[str]) -> str:
    """The part that publishes /clock: the simulated base, else the controller, else the first."""
    for name in parts:
        if is_simulated_base(config, name):
            return name
    return CONTROLLER if CONTROLLER in parts else parts[0]


def _wait_for_epoch(namespace: str, name: str) -> float:
    """Report this node ready under ``namespace`` and wait for the launch to fix the origin."""
    master = Master(caller=f"/{name}")
    master.set(f"{namespace}/ready/{name}", True)
    deadline = time.monotonic() + READY_TIMEOUT + 30
    while True:
        epoch = master.get(f"{namespace}/epoch")
        if isinstance(epoch, int | float) and not isinstance(epoch, bool):
            return float(epoch)
        if time.monotonic() > deadline:
            raise CyborgError(
                f"no origin of virtual time appeared at {namespace}/epoch; fix: start this node with "
                "`cyborg launch --speed N`, or give it --epoch UNIX_SECONDS"
            )
        time.sleep(0.05)


# --- one node -----------------------------------------------------------------------------


@dataclass
class ScenarioFiles:
    """What the ``cyborg_scenario`` node plays and where it writes."""

    script: Path
    transcript: Path | None = None


def run_node(
    name: str,
    config: LoadedConfig,
    data_dir: Path,
    map_path: Path | None,
    host: str,
    port: int,
    seed: int,
    *,
    sim_time: SimTime | None = None,
    publish_clock_too: bool | None = None,
    scenario: ScenarioFiles | None = None,
    resume: bool = True,
    access: Access | None = None,
) -> None:
    """Run part ``name`` as the ROS node of the same name until SIGINT/SIGTERM.

    ``resume``: the controller may take over a recently stored emotion (see ``build_controller``).

    ``publish_clock_too``: publish /clock (with a speed only); None: when the part is a simulated base.
    ``cyborg_scenario`` (with ``scenario``) plays its script and stops at the script's end.
    """
    require_ros()
    if not master_running():
        raise CyborgError(
            f"no ROS master answers at {master_uri()}; fix: start roscore, or use `cyborg launch`"
        )
    from cyborg.transport.ros import RosTransport

    sim_time = sim_time or SimTime()
    clock = sim_time.make_clock()
    transport = RosTransport(clock, process_name=name)
    context = NodeContext(data_dir=data_dir, rng=random.Random(seed), map_path=map_path, resume=resume)
    driver = None
    if name == SCENARIO:
        if scenario is None:
            raise CyborgError(f"{SCENARIO} plays a script; fix: give it --script FILE")
        driver = _ScenarioNode(transport.node(SCENARIO), scenario)
        part = Part(name, [driver])
    else:
        part = build_part(name, config, transport, context)
    show_problems_on_stderr(name)
    if publish_clock_too is None:
        publish_clock_too = is_simulated_base(config, name)
    clock_publisher = None
    if publish_clock_too and sim_time.virtual:
        # Made now, so every node is connected when the time starts (they all wait for /clock).
        clock_node = transport.node(f"{name}_clock")
        clock_publisher = clock_node.publisher(CLOCK_TOPIC, ClockMessage, queue_size=1)
    stats_publisher = None
    if part.controller is not None:  # its counters, for the cyborg_api node's dashboard
        stats_publisher = part.controller.node.publisher(topics.CONTROLLER_STATS, String, latch=True)

    try:
        namespace = sim_time.epoch_params
        if namespace is not None:
            assert isinstance(clock, VirtualClock)
            clock.anchor(_wait_for_epoch(namespace, name))
        if isinstance(clock, VirtualClock) and clock.real_origin > time.time():
            time.sleep(clock.real_origin - time.time())  # everyone starts at the origin
    except KeyboardInterrupt:
        transport.close("cyborg node stopped before it started")
        clock.close()
        return

    async def main() -> int:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        background: list[asyncio.Task[None]] = []
        if clock_publisher is not None:
            assert isinstance(clock, VirtualClock)
            background.append(loop.create_task(publish_clock(clock_publisher, clock), name="clock"))
        if stats_publisher is not None and part.controller is not None:
            from cyborg.interfaces.remote import publish_controller_stats

            counters = publish_controller_stats(stats_publisher, part.controller)
            background.append(loop.create_task(counters, name="controller stats"))
        api = None
        if name == API:
            from cyborg.interfaces import dashboard
            from cyborg.interfaces.api import RobotAPI
            from cyborg.interfaces.remote import remote_robot

            api_node = transport.node(API)
            api = RobotAPI(
                api_node,
                machine=config.machine,
                emotions=dict(config.model.emotion.prototypes),
                emotion_aliases=config.model.emotion.usable_aliases(),
                access=access,
            )
            has_base = any(
                isinstance(m, dict) and m.get("kind") == "simulated_base"
                for m in config.model.modules.values()
            )
            mirror = remote_robot(api_node, config, context.occupancy_map() if has_base else None)
            api.extra_status = lambda: {"emotion_enabled": mirror.emotion_enabled()}
            dashboard.register(api, mirror)
            given = access is not None and access.token is not None
            url = await api.start(host, port)
            for text, colour in announcement(url, host, api.port or port, api.token, generated=not given):
                click.secho(text, fg=colour, err=True)
        freeze_built()  # what the part built lives as long as the node: out of GC's way (app.memory)
        controller_task = part.controller.start() if part.controller is not None else None
        click.echo(f"node {name} running", err=True)
        if driver is not None:
            run = asyncio.ensure_future(driver.play())
            waiter = asyncio.ensure_future(stop.wait())
            await asyncio.wait({run, waiter}, return_when=asyncio.FIRST_COMPLETED)
            waiter.cancel()
            if not run.done():
                run.cancel()
                return 1
            run.result()
            click.echo(f"node {name}: script ended, {driver.driver.count} records", err=True)
            return 0
        waiter = asyncio.ensure_future(stop.wait())
        await asyncio.wait(
            {waiter, *([controller_task] if controller_task else [])}, return_when=asyncio.FIRST_COMPLETED
        )
        waiter.cancel()
        if controller_task is not None and controller_task.done():
            # It logged why (critical). Leave, so that `cyborg launch` (or roslaunch's respawn) starts it again.
            click.echo(f"node {name}: the controller stopped; ending this node with exit code 1", err=True)
            if api is not None:
                await api.stop()
            return 1
        if part.controller is not None:
            await part.controller.stop()
        if api is not None:
            await api.stop()
        return 0

    try:
        code = clock.run(main())
    finally:
        transport.close()
        clock.close()
    if code:
        raise SystemExit(code)


def node_log_file(name: str) -> Path:
    """Where rospy writes every log line of node ``name`` in this environment."""
    import rospkg  # type: ignore[import-not-found]

    return Path(rospkg.get_log_dir()) / f"{name}.log"


class _OneWrite(logging.Formatter):
    """A record (traceback included) as one string ending in a newline, written in one go."""

    def format(self, record: logging.LogRecord) -> str:
        return super().format(record).rstrip("\n") + "\n"


def show_problems_on_stderr(name: str) -> None:
    """Warnings and errors of this node also go to stderr, prefixed ``[name]``.

    rospy sends the log to the node's file only (:func:`node_log_file`); under ``cyborg launch``
    every node's stderr is the launch's terminal, so problems show where the person looks.
    """
    root = logging.getLogger()
    if any(
        isinstance(h, logging.StreamHandler) and getattr(h, "stream", None) is sys.stderr
        for h in root.handlers
    ):
        return  # rospy left the command line's own handler in place: it shows them already
    handler = logging.StreamHandler(sys.stderr)
    handler.terminator = ""  # one write per line: the nodes share the terminal
    handler.setLevel(logging.WARNING)
    handler.setFormatter(_OneWrite(f"[{name}] %(levelname)s %(name)s: %(message)s"))
    logging.getLogger("cyborg").addHandler(handler)


class _ScenarioNode:
    """The ``cyborg_scenario`` node: a :class:`ScenarioDriver` writing its transcript as it goes."""

    def __init__(self, node: Node, files: ScenarioFiles) -> None:
        from cyborg.sim.scenario import ScenarioDriver
        from cyborg.sim.script import load_script

        self.node = node
        self.script = load_script(files.script)
        # With a transcript file the records go there as they come and none is kept (flat memory).
        self.driver = ScenarioDriver(node, self.script, keep_records=files.transcript is None)
        self._out: IO[str] | None = None
        if files.transcript is not None:
            self._out = files.transcript.open("w", encoding="utf-8")
            self.driver.listeners.append(self._write)
        # Before reporting ready: wait until the robot listens, so the first steps reach it.
        # (Our own RecordStream is one of the listeners to what is "heard".)
        deadline = time.monotonic() + READY_TIMEOUT
        for publisher, listeners in ((self.driver.event, 1), (self.driver.say, 2)):
            while publisher.subscriber_count() < listeners and time.monotonic() < deadline:
                time.sleep(0.02)

    def _write(self, record: dict[str, Any]) -> None:
        assert self._out is not None
        self._out.write(json.dumps(record) + "\n")
        self._out.flush()

    def close(self) -> None:
        """Close the transcript (what was written stays)."""
        if self._out is not None and not self._out.closed:
            self._out.close()

    async def play(self) -> None:
        try:
            if self.script.emotion:
                self.driver.set_emotion.publish(String(self.script.emotion))
            await self.driver.run()
        finally:
            if self._out is not None:
                self._out.close()
        if self.driver.failures:
            from cyborg.errors import ScenarioFailed

            raise ScenarioFailed(self.driver.failures, source=self.script.source)
