"""``cyborg node NAME``: one part of the robot as a ROS node, and what launches share with it.

ROS 1 needs scripts/install-ros and a master (``roscore``; ``cyborg launch`` starts one when
none answers at ``ROS_MASTER_URI``). ROS 2 (``--ros2``) needs scripts/install-ros2 and no
master: the node runs in ``.venv-ros2``'s Python (:mod:`cyborg.interfaces.ros2_env`), its
nodes are rclpy nodes with ``use_sim_time`` set in virtual time, and a launch meets its nodes in
a folder instead of on the parameter server (:class:`FolderRendezvous`).

Simulated time (``--speed N``): every node runs a :class:`VirtualClock` at speed N from one
origin, so their virtual times agree. ``cyborg node --epoch T`` gives the origin as a wall-clock
time; ``cyborg launch --speed N`` sets ``/use_sim_time``, starts the nodes with ``--epoch
param:NS`` (ROS 2: ``--epoch dir:FOLDER``) and, once every node is built and waiting, fixes the
origin in the parameter ``NS/epoch`` (the file ``FOLDER/epoch``): nodes take seconds to start,
so a time chosen in advance would be missed or wasted. The simulated base (``rosarnl_node``;
the controller when no base runs) publishes ``/clock`` from its clock ~10 times a real second,
so ``rostopic``, ``rosbag`` and actionlib's timers follow the simulated time too (ROS 2: every
rclpy node of ours has ``use_sim_time``).

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
from typing import IO, TYPE_CHECKING, Any, Protocol

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

if TYPE_CHECKING:
    from cyborg.transport.ros import RosTransport
    from cyborg.transport.ros2 import Ros2Transport

log = logging.getLogger(__name__)

SCENARIO = "cyborg_scenario"
CLOCK_TOPIC = "/clock"
CLOCK_RATE = 10.0  # /clock messages per real second
USE_SIM_TIME = "/use_sim_time"
SIM_PARAMS = "/cyborg_sim"  # a launch's shared-time parameters live under SIM_PARAMS/<run id>
EPOCH_PARAM_PREFIX = "param:"
EPOCH_DIR_PREFIX = "dir:"
EPOCH_MARGIN = 0.5  # real seconds between the last node being ready and virtual time starting
CONNECT_TIMEOUT = 5.0  # real seconds a node waits for its topics' connections before it starts
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


# --- where a launch and its nodes meet -----------------------------------------------------


class Rendezvous(Protocol):
    """Where a launch's nodes say they are ready and read the origin of virtual time."""

    def mark_ready(self, name: str) -> None: ...
    def ready_names(self) -> set[str]: ...
    def set_epoch(self, epoch: float) -> None: ...
    def epoch(self) -> float | None: ...


class MasterRendezvous:
    """ROS 1: parameters under ``namespace`` on the master (``NS/ready/NAME``, ``NS/epoch``)."""

    def __init__(self, namespace: str, caller: str = "/cyborg_launch") -> None:
        self.namespace = namespace.rstrip("/")
        self.master = Master(caller=caller)

    def mark_ready(self, name: str) -> None:
        self.master.set(f"{self.namespace}/ready/{name}", True)

    def ready_names(self) -> set[str]:
        ready = self.master.get(f"{self.namespace}/ready", {})
        return {name for name, value in ready.items() if value} if isinstance(ready, dict) else set()

    def set_epoch(self, epoch: float) -> None:
        self.master.set(f"{self.namespace}/epoch", epoch)

    def epoch(self) -> float | None:
        epoch = self.master.get(f"{self.namespace}/epoch")
        return float(epoch) if isinstance(epoch, int | float) and not isinstance(epoch, bool) else None


class FolderRendezvous:
    """ROS 2 (no master): files in ``folder``, ``ready/NAME`` and ``epoch`` (written whole, then renamed)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def mark_ready(self, name: str) -> None:
        (self.folder / "ready").mkdir(parents=True, exist_ok=True)
        (self.folder / "ready" / name).touch()

    def ready_names(self) -> set[str]:
        folder = self.folder / "ready"
        return {path.name for path in folder.iterdir()} if folder.is_dir() else set()

    def set_epoch(self, epoch: float) -> None:
        partial = self.folder / "epoch.partial"
        partial.write_text(repr(epoch), encoding="utf-8")
        partial.replace(self.folder / "epoch")

    def epoch(self) -> float | None:
        try:
            return float((self.folder / "epoch").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None


# --- time options of a node -------------------------------------------------------------


@dataclass(frozen=True)
class SimTime:
    """How a node keeps time: real time, or virtual time at ``speed`` from a shared origin.

    ``epoch``: the wall-clock time (Unix seconds) at which virtual time reads ``start``; or
    ``param:NS`` (ROS 1) / ``dir:FOLDER`` (ROS 2), to wait for the launch to set ``NS/epoch``
    (``FOLDER/epoch``) once every node is ready; or None: the moment the node starts.
    """

    speed: float | None = None
    epoch: float | str | None = None
    start: datetime = DEFAULT_VIRTUAL_START

    @property
    def virtual(self) -> bool:
        return self.speed is not None

    @property
    def rendezvous(self) -> Rendezvous | None:
        """Where the launch sets the origin, when it does."""
        if isinstance(self.epoch, str) and self.epoch.startswith(EPOCH_PARAM_PREFIX):
            return MasterRendezvous(
                self.epoch[len(EPOCH_PARAM_PREFIX) :], caller=f"/cyborg_node_{os.getpid()}"
            )
        if isinstance(self.epoch, str) and self.epoch.startswith(EPOCH_DIR_PREFIX):
            return FolderRendezvous(Path(self.epoch[len(EPOCH_DIR_PREFIX) :]))
        return None

    def make_clock(self) -> Clock:
        if self.speed is None:
            if self.epoch is not None:
                raise CyborgError("--epoch goes with --speed: real time needs no shared origin")
            return RealClock()
        if isinstance(self.epoch, str):
            origin = math.inf  # stands still until the launch fixes the origin
        elif self.epoch is None:
            origin = time.time()
        else:
            origin = float(self.epoch)
        return VirtualClock(self.start, self.speed, real_origin=origin)


def parse_epoch(value: str | None) -> float | str | None:
    """``--epoch``: Unix seconds (``1795424400.5``), ``param:/cyborg_sim/RUN`` or ``dir:FOLDER``."""
    if value is None or value.startswith((EPOCH_PARAM_PREFIX, EPOCH_DIR_PREFIX)):
        return value
    try:
        return float(value)
    except ValueError:
        raise click.BadParameter(
            f"{value!r} is neither a time in Unix seconds (e.g. {time.time():.1f}) nor param:NAMESPACE "
            "nor dir:FOLDER"
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


def _wait_for_epoch(rendezvous: Rendezvous, name: str) -> float:
    """Report this node ready and wait for the launch to fix the origin."""
    rendezvous.mark_ready(name)
    deadline = time.monotonic() + READY_TIMEOUT + 30
    while True:
        epoch = rendezvous.epoch()
        if epoch is not None:
            return epoch
        if time.monotonic() > deadline:
            raise CyborgError(
                "no origin of virtual time appeared (the launch sets it once every node is ready); "
                "fix: start this node with `cyborg launch --speed N`, or give it --epoch UNIX_SECONDS"
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
    ros2: bool = False,
) -> None:
    """Run part ``name`` as the ROS node of the same name until SIGINT/SIGTERM.

    ``ros2``: on ROS 2 (rclpy, in this Python; no master), every node with ``use_sim_time`` in virtual
    time; the log goes to :func:`node_log_file` as rospy's does.

    ``resume``: the controller may take over a recently stored emotion (see ``build_controller``).

    ``publish_clock_too``: publish /clock (with a speed only); None: when the part is a simulated base.
    ``cyborg_scenario`` (with ``scenario``) plays its script and stops at the script's end.
    """
    sim_time = sim_time or SimTime()
    transport: RosTransport | Ros2Transport
    if ros2:
        require_ros2()
        from cyborg.transport.ros2 import Ros2Transport

        log_to_file(name, ros2=True)
        clock = sim_time.make_clock()
        transport = Ros2Transport(clock, use_sim_time=sim_time.virtual)
    else:
        require_ros()
        if not master_running():
            raise CyborgError(
                f"no ROS master answers at {master_uri()}; fix: start roscore, or use `cyborg launch`"
            )
        from cyborg.transport.ros import RosTransport

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
    if not ros2:
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

    missing = transport.wait_for_connections(CONNECT_TIMEOUT)
    if missing:  # e.g. a node killed without leaving the graph: the node starts anyway
        log.warning(
            "%d connection(s) not made within %.0f s, whose first messages may be lost: %s",
            len(missing),
            CONNECT_TIMEOUT,
            "; ".join(missing[:5]) + (" ..." if len(missing) > 5 else ""),
        )
    try:
        rendezvous = sim_time.rendezvous
        if rendezvous is not None:
            assert isinstance(clock, VirtualClock)
            clock.anchor(_wait_for_epoch(rendezvous, name))
        if isinstance(clock, VirtualClock) and clock.real_origin > time.time():
            time.sleep(clock.real_origin - time.time())  # everyone starts at the origin
    except KeyboardInterrupt:
        transport.close()
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


def require_ros2() -> None:
    try:
        import cyborg.transport.ros2  # noqa: F401  (imports rclpy and our ROS 2 interfaces)
    except ImportError as exc:
        raise CyborgError(
            f"ROS 2 is not available in this Python ({exc}); fix: run scripts/install-ros2 and use "
            ".venv-ros2/bin/cyborg (a --ros2 command in the main venv runs there by itself)"
        ) from None


def node_log_file(name: str, *, ros2: bool = False) -> Path:
    """Where every log line of node ``name`` goes in this environment: rospy's log folder, or
    for ROS 2 ``$ROS_LOG_DIR`` (default ``$ROS_HOME/log``, ``~/.ros/log``)."""
    if ros2:
        home = Path(os.environ.get("ROS_HOME") or Path.home() / ".ros")
        return Path(os.environ.get("ROS_LOG_DIR") or home / "log") / f"{name}.log"
    import rospkg  # type: ignore[import-not-found]

    return Path(rospkg.get_log_dir()) / f"{name}.log"


def log_to_file(name: str, *, ros2: bool) -> None:
    """Every log line of this node to :func:`node_log_file` (as rospy does on ROS 1), warnings and
    errors also to stderr (:func:`show_problems_on_stderr`)."""
    path = node_log_file(name, ros2=ros2)
    path.parent.mkdir(parents=True, exist_ok=True)
    root = logging.getLogger()
    for handler in list(root.handlers):
        if isinstance(handler, logging.StreamHandler) and getattr(handler, "stream", None) is sys.stderr:
            root.removeHandler(handler)
    to_file = logging.FileHandler(path, encoding="utf-8")
    to_file.setFormatter(logging.Formatter("%(asctime)s %(levelname)-7s %(name)s: %(message)s"))
    root.addHandler(to_file)
    show_problems_on_stderr(name)


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
