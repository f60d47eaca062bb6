"""``cyborg node NAME``, ``cyborg launch`` and ``cyborg sim --ros``: the robot as ROS 1 nodes.

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
import math
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
import urllib.parse
import uuid
import xml.sax.saxutils
import xmlrpc.client
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

import click

from cyborg.controller.config import LoadedConfig
from cyborg.errors import CyborgError
from cyborg.sim.nodes import API, CONTROLLER, NodeContext, Part, build_part, part_names
from cyborg.sim.script import Script
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
) -> None:
    """Run part ``name`` as the ROS node of the same name until SIGINT/SIGTERM.

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
    context = NodeContext(data_dir=data_dir, rng=random.Random(seed), map_path=map_path)
    driver = None
    if name == SCENARIO:
        if scenario is None:
            raise CyborgError(f"{SCENARIO} plays a script; fix: give it --script FILE")
        driver = _scenario_driver(transport.node(SCENARIO), scenario)
        part = Part(name, [driver])
    else:
        part = build_part(name, config, transport, context)
    if publish_clock_too is None:
        publish_clock_too = is_simulated_base(config, name)
    clock_publisher = None
    if publish_clock_too and sim_time.virtual:
        # Made now, so every node is connected when the time starts (they all wait for /clock).
        clock_node = transport.node(f"{name}_clock")
        clock_publisher = clock_node.publisher(CLOCK_TOPIC, ClockMessage, queue_size=1)

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
        api = None
        if name == API:
            from cyborg.interfaces import dashboard
            from cyborg.interfaces.api import RobotAPI
            from cyborg.interfaces.remote import remote_robot

            api_node = transport.node(API)
            api = RobotAPI(api_node, machine=config.machine, emotions=dict(config.model.emotion.prototypes))
            has_base = any(
                isinstance(m, dict) and m.get("kind") == "simulated_base"
                for m in config.model.modules.values()
            )
            mirror = remote_robot(api_node, config, context.occupancy_map() if has_base else None)
            dashboard.register(api, mirror)  # type: ignore[arg-type]
            url = await api.start(host, port)
            click.echo(f"API: {url}", err=True)
        if part.controller is not None:
            part.controller.start()
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
            click.echo(f"node {name}: script ended, {len(driver.records)} records", err=True)
            return 0
        await stop.wait()
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


class _ScenarioNode:
    """The ``cyborg_scenario`` node: a :class:`ScenarioDriver` writing its transcript as it goes."""

    def __init__(self, node: Node, files: ScenarioFiles) -> None:
        from cyborg.sim.scenario import ScenarioDriver
        from cyborg.sim.script import load_script

        self.script = load_script(files.script)
        self.driver = ScenarioDriver(node, self.script)
        self.records = self.driver.records
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

    async def play(self) -> None:
        try:
            if self.script.emotion:
                self.driver.set_emotion.publish(String(self.script.emotion))
            await self.driver.run()
        finally:
            if self._out is not None:
                self._out.close()


def _scenario_driver(node: Node, files: ScenarioFiles) -> _ScenarioNode:
    return _ScenarioNode(node, files)


# --- a whole robot ------------------------------------------------------------------------


def start_master(port: int, log_dir: Path) -> subprocess.Popen[bytes]:
    log_dir.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "ROS_HOME": str(log_dir)}
    process = subprocess.Popen(
        ["roscore", "-p", str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env
    )
    uri = f"http://localhost:{port}"
    deadline = time.monotonic() + 20
    while not master_running(uri):
        if process.poll() is not None or time.monotonic() > deadline:
            process.send_signal(signal.SIGINT)
            raise CyborgError("roscore did not start; fix: check that ROS is installed (scripts/install-ros)")
        time.sleep(0.1)
    return process


@dataclass
class Launch:
    """A master if none runs, then every part as its own ``cyborg node`` process.

    With ``speed``: /use_sim_time is set (and put back afterwards), the parts share one origin
    of virtual time (fixed once all are ready) and the clock publisher starts first.
    """

    config_path: Path
    config: LoadedConfig
    parts: list[str]
    data_dir: Path
    map_path: Path | None = None
    port: int = 8642
    echo: bool = True
    speed: float | None = None
    start: datetime = DEFAULT_VIRTUAL_START
    seed: int = 0
    extra_args: dict[str, list[str]] = field(default_factory=dict)
    say: Callable[[str], None] = click.echo
    master: subprocess.Popen[bytes] | None = None
    processes: dict[str, subprocess.Popen[bytes]] = field(default_factory=dict)
    _namespace: str | None = None
    _saved_sim_time: Any = None
    _touched_sim_time: bool = False

    def command(self, name: str, clock_owner: str | None) -> list[str]:
        command = [
            sys.executable,
            "-m",
            "cyborg.interfaces.cli",
            "node",
            name,
            "--config",
            str(self.config_path),
            "--db",
            str(self.data_dir),
            "--seed",
            str(self.seed),
        ]
        if self.map_path is not None:
            command += ["--map", str(self.map_path)]
        if name == API:
            command += ["--port", str(self.port)]
        if self.speed is not None:
            assert self._namespace is not None
            command += [
                "--speed",
                repr(self.speed),
                "--epoch",
                EPOCH_PARAM_PREFIX + self._namespace,
                "--start",
                self.start.isoformat(),
                "--publish-clock" if name == clock_owner else "--no-publish-clock",
            ]
        return command + self.extra_args.get(name, [])

    def start_all(self) -> None:
        require_ros()
        if not master_running():
            parsed = urllib.parse.urlparse(master_uri())
            self.master = start_master(parsed.port or 11311, self.data_dir / "ros")
            self.say(f"started roscore at {master_uri()}")
        master = Master()
        self._saved_sim_time = master.get(USE_SIM_TIME) if master.has(USE_SIM_TIME) else None
        clock_owner = None
        if self.speed is not None:
            self._namespace = f"{SIM_PARAMS}/run_{uuid.uuid4().hex[:12]}"
            clock_owner = clock_owner_of(self.config, self.parts)
            self.parts.sort(key=lambda name: name != clock_owner)  # /clock first: the others wait for it
            master.set(USE_SIM_TIME, True)
            self._touched_sim_time = True
        elif self._saved_sim_time:
            master.set(USE_SIM_TIME, False)  # left over from a simulated run: nodes would wait for /clock
            self._touched_sim_time = True
        for name in self.parts:
            self.processes[name] = subprocess.Popen(
                self.command(name, clock_owner), stdout=None if self.echo else subprocess.DEVNULL
            )
        self.say(f"launched {len(self.processes)} nodes: {', '.join(self.parts)}")
        if self.speed is not None:
            self._start_virtual_time(master)

    def _start_virtual_time(self, master: Master) -> None:
        assert self._namespace is not None
        deadline = time.monotonic() + READY_TIMEOUT
        while True:
            ready = master.get(f"{self._namespace}/ready", {})
            waiting = [name for name in self.parts if not (isinstance(ready, dict) and ready.get(name))]
            if not waiting:
                break
            self.check_alive()
            if time.monotonic() > deadline:
                raise CyborgError(
                    f"node(s) not ready within {READY_TIMEOUT:.0f} s: {', '.join(waiting)}; "
                    "fix: check their output above"
                )
            time.sleep(0.05)
        epoch = time.time() + EPOCH_MARGIN
        master.set(f"{self._namespace}/epoch", epoch)
        self.say(
            f"virtual time: {self.start.isoformat()} at speed {self.speed:g}, "
            f"starting at {datetime.fromtimestamp(epoch, UTC):%H:%M:%S.%f} UTC"
        )

    def check_alive(self, ignore: Sequence[str] = ()) -> None:
        failed = [n for n, p in self.processes.items() if n not in ignore and p.poll() is not None]
        if failed:
            raise CyborgError(f"node(s) stopped: {', '.join(failed)}; the whole robot is stopped too")

    def wait(self, *, until: str | None = None, timeout: float | None = None) -> int | None:
        """Until a node stops (an error), node ``until`` ends (its exit code) or ``timeout`` real seconds pass."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            if until is not None and self.processes[until].poll() is not None:
                return self.processes[until].returncode
            self.check_alive(ignore=[until] if until else [])
            if deadline is not None and time.monotonic() > deadline:
                return None
            time.sleep(0.1)

    def stop_all(self) -> None:
        try:
            for process in self.processes.values():
                if process.poll() is None:
                    process.send_signal(signal.SIGINT)
            for process in self.processes.values():
                with contextlib.suppress(subprocess.TimeoutExpired):
                    process.wait(timeout=10)
                if process.poll() is None:
                    process.kill()
                    process.wait(timeout=5)
            if self.master is None and master_running():
                master = Master()
                if self._namespace is not None:
                    master.delete(self._namespace)
                if self._touched_sim_time:
                    if self._saved_sim_time is None:
                        master.delete(USE_SIM_TIME)
                    else:
                        master.set(USE_SIM_TIME, self._saved_sim_time)
        finally:
            if self.master is not None:
                self.master.send_signal(signal.SIGINT)
                try:
                    self.master.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    self.master.kill()
                    self.master.wait(timeout=5)


def launch(
    config_path: Path,
    config: LoadedConfig,
    parts: list[str],
    data_dir: Path,
    map_path: Path | None,
    port: int,
    echo: bool,
    *,
    speed: float | None = None,
    start: datetime = DEFAULT_VIRTUAL_START,
    duration: float | None = None,
) -> None:
    """Start a master if needed, then every part as its own `cyborg node` process, until stopped.

    ``duration``: stop after that many seconds (virtual with a speed).
    """

    def stop_on_term(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop_on_term)  # `kill` and `timeout` stop the nodes too
    robot = Launch(config_path, config, list(parts), data_dir, map_path, port, echo, speed=speed, start=start)
    try:
        robot.start_all()
        real_duration = None if duration is None else duration / (speed or 1.0)
        robot.wait(timeout=real_duration)
    except KeyboardInterrupt:
        click.echo("stopping")
    finally:
        robot.stop_all()


def prepare_calendar(config: LoadedConfig, data_dir: Path, map_path: Path | None, script: Script) -> None:
    """Put a script's calendar entries into the navigation module's database before its node starts."""
    if not script.calendar:
        return
    from cyborg.sim.scenario import add_calendar
    from cyborg.transport.embedded import EmbeddedTransport

    context = NodeContext(data_dir=data_dir, rng=random.Random(0), map_path=map_path)
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    try:
        for name, raw in config.model.modules.items():
            if isinstance(raw, dict) and raw.get("kind") == "navigation":
                build_part(name, config, transport, context)  # what the node will open
                break
        add_calendar(context.calendar, script)
    finally:
        transport.shutdown()
        clock.close()


def run_scenario_ros(
    config_path: Path,
    config: LoadedConfig,
    script_path: Path,
    *,
    transcript_path: Path | None,
    speed: float,
    data_dir: Path | None,
    map_path: Path | None,
    echo: bool = False,
    say: Callable[[str], None] = click.echo,
) -> list[dict[str, Any]]:
    """Run a scenario over ROS: the robot's nodes (no API) plus ``cyborg_scenario``; return the records."""
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
        parts = [name for name in part_names(config) if name != API] + [SCENARIO]
        robot = Launch(
            config_path,
            config,
            parts,
            data_dir,
            map_path,
            echo=echo,
            speed=speed,
            start=script_start(script),
            seed=script.seed,
            extra_args={
                SCENARIO: ["--script", str(script_path.resolve()), "--transcript", str(transcript_path)]
            },
            say=say,
        )
        try:
            robot.start_all()
            code = robot.wait(until=SCENARIO)
        finally:
            robot.stop_all()
        if code != 0:
            raise CyborgError(f"{SCENARIO} ended with exit code {code}; see its output above")
        return [json.loads(line) for line in transcript_path.read_text(encoding="utf-8").splitlines()]


def roslaunch_xml(config_path: Path, parts: list[str], data_dir: Path) -> str:
    """A roslaunch file starting the same nodes (for people who prefer roslaunch)."""
    lines = [
        "<launch>",
        "  <!-- written by cyborg launch (write option): one node per part; the roslaunch node name is",
        "       the part's, since roslaunch renames the node it starts and gatekeepers go by names -->",
    ]
    for name in parts:
        args = xml.sax.saxutils.quoteattr(f"node {name} --config {config_path} --db {data_dir}")
        lines.append(
            f'  <node name="{name}" pkg="cyborg_controller" type="cyborg" args={args} required="true" output="screen"/>'
        )
    lines.append("</launch>")
    return "\n".join(lines) + "\n"


def all_parts(config: LoadedConfig) -> list[str]:
    return part_names(config)
