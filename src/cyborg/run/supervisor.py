"""``cyborg launch`` and ``cyborg sim --ros``: the whole robot as ROS nodes, one process per part.

Each part runs as ``cyborg node NAME`` (:mod:`cyborg.run.node`) on the launch's middleware
(:mod:`cyborg.run.middleware`), which prepares the graph first: ROS 1 starts a master when none
answers at ``ROS_MASTER_URI`` and sets ``/use_sim_time`` with a speed; ROS 2 (``--ros2``, nodes
in ``.venv-ros2``'s Python) has no master, and its nodes meet the launch in a folder. With a
speed the launch fixes the shared origin of virtual time once every node is ready
(:mod:`cyborg.run.simtime`). ``cyborg sim --ros --script FILE`` adds the ``cyborg_scenario``
node (:mod:`cyborg.run.scenario`).

On ROS 2 the launch shares one process among the thin parts (:func:`shared_process`: the
built-in light module kinds and the gatekeepers), and another between the API and the recorder,
each still its own node on the graph, so a gatekeeper tells them apart as before; ROS 1 runs one node per process (rospy's rule, and a
gatekeeper knows a sender by its process's node name). ``cyborg launch --processes`` chooses.

A node that refuses to start because its name is taken on the graph (another robot there, or a
node of its name: :mod:`cyborg.run.census`) stops the whole launch with that reason instead.

``cyborg launch`` keeps the robot running when a node stops: it says so and starts that node again
(as roslaunch's ``respawn``), after RESPAWN_DELAY seconds, doubled for each stop within
RESPAWN_STEADY seconds of its start, up to RESPAWN_MAX_DELAY. The controller comes back without
``--fresh``, so it resumes the emotion it stored. A roscore the launch started is started again on
its port; every node registers again with it (:mod:`cyborg.transport.ros`).
"""

from __future__ import annotations

import contextlib
import signal
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import click

from cyborg.app.config import LoadedConfig
from cyborg.app.parts import API, CONTROLLER, RECORDER
from cyborg.app.sketch import text_digest
from cyborg.errors import CyborgError
from cyborg.run.census import NAME_TAKEN_EXIT
from cyborg.run.lockstep import TimeServer
from cyborg.run.middleware import ROS1, LaunchGraph, Middleware, exit_description
from cyborg.run.simtime import EPOCH_MARGIN, READY_TIMEOUT, Rendezvous, check_virtual_time, clock_owner_of
from cyborg.run.zygote import ForkedNode, Zygote
from cyborg.transport.clock import DEFAULT_VIRTUAL_START, NS

__all__ = ["THIN_KINDS", "Launch", "is_thin", "launch", "shared_process", "start_zygote"]

RESPAWN_DELAY = 1.0  # seconds before a stopped node is started again
RESPAWN_STEADY = 10.0  # a node that ran this long before it stopped is started again after RESPAWN_DELAY
RESPAWN_MAX_DELAY = 30.0  # a node stopping again and again waits at most this long
REFUSAL_GRACE = 5.0  # seconds a refused node's launch waits for the controller's own reason
IDLE_LOOK = 1.0
"""Seconds between two looks at the nodes while the zygote tells their ends (a master the launch
started that stops is seen within this, as is the end of a --duration)."""


THIN_KINDS = frozenset({"conversation", "event_script", "idle", "music", "placeholder", "question", "tts"})
"""Built-in module kinds that only wait, talk and publish (their settings are dataclasses): they
may share one process, and their nodes start without click or pydantic (:mod:`cyborg.run.launched`)."""


def start_zygote(middleware: Middleware, *, echo: bool = True) -> Zygote:
    """A zygote for ``middleware``'s nodes (:mod:`cyborg.run.zygote`), importing from now on."""
    return Zygote(middleware.python(), middleware.environment(), middleware.preload, echo=echo)


def shared_process(config: LoadedConfig, parts: Sequence[str]) -> dict[str, list[str]]:
    """The thin parts among ``parts`` as one process: {the first: the others it hosts} (none
    when fewer than two are thin); and the recorder in the API's process (both only listen to
    the graph, and both hear every pose: in one process one wake-up of its executor takes both
    copies of a message)."""
    names = [name for name in parts if is_thin(config, name)]
    shared = {names[0]: names[1:]} if len(names) > 1 else {}
    if API in parts and RECORDER in parts:
        shared[API] = [RECORDER]
    return shared


def is_thin(config: LoadedConfig, name: str) -> bool:
    """Whether part ``name`` is a gatekeeper or a module of a built-in thin kind (:data:`THIN_KINDS`:
    they only wait, talk and publish). Other kinds (the navigation, the simulated base, speech
    input, every plug-in's) keep a process of their own, started as ``cyborg node``."""
    raw = config.model.modules.get(name)
    gates = {gate.name for gate in config.model.gatekeepers}
    return name in gates or (isinstance(raw, dict) and raw.get("kind") in THIN_KINDS)


@dataclass
class Launch:
    """The graph prepared by the middleware, then every part as its own ``cyborg node`` process.

    With ``speed``: the parts share one origin of virtual time (fixed once all are ready) and the
    clock publisher starts first. With ``respawn``: once started, a node that stops is started
    again (see the module's doc).
    """

    config_path: Path
    config: LoadedConfig
    parts: list[str]
    data_dir: Path
    map_path: Path | None = None
    port: int = 8642
    echo: bool = True
    speed: float | None = None
    lockstep: bool = False
    """Virtual time as fast as the graph allows, granted by a time server the launch runs
    (:mod:`cyborg.run.lockstep`): ``--speed max``. Excludes ``speed``."""
    start: datetime = DEFAULT_VIRTUAL_START
    seed: int = 0
    extra_args: dict[str, list[str]] = field(default_factory=dict)
    say: Callable[[str], None] = click.echo
    processes: dict[str, subprocess.Popen[bytes] | ForkedNode] = field(default_factory=dict)
    respawn: bool = False
    middleware: Middleware = ROS1
    hosts: dict[str, list[str]] = field(default_factory=dict)
    """A process's node name -> the parts it hosts beside its own (each its own node; ROS 2 only)."""
    fork: bool = True
    """Fork the node processes from a zygote that imported what they all import (:mod:`cyborg.run.zygote`)."""
    zygote: Zygote | None = None
    """A zygote started already (:func:`start_zygote`); with ``fork`` and none, the launch starts one."""
    _graph: LaunchGraph | None = None
    _rendezvous: Rendezvous | None = None
    _epoch_argument: str | None = None
    _clock_owner: str | None = None
    _time_server: TimeServer | None = None
    _started_at: dict[str, float] = field(default_factory=dict)
    _respawn_delay: dict[str, float] = field(default_factory=dict)
    _respawn_at: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.speed is not None or self.lockstep:
            check_virtual_time(self.config)
        if self.hosts and not self.middleware.hosts_many:
            raise CyborgError(
                f"{self.middleware.name} runs one node per process: no part can host another; "
                "fix: launch with --processes per-part, or on ROS 2 (--ros2)"
            )
        hosted = {name for names in self.hosts.values() for name in names}
        self.parts = [name for name in self.parts if name not in hosted]  # a process each

    def command(self, name: str, clock_owner: str | None, *, fresh: bool = True) -> list[str]:
        """The command line of part ``name``'s process: ``python -m cyborg.cli node NAME ...``, or for
        a thin part of a file validated here ``python -m cyborg.run.launched node NAME ...``, which
        loads neither click nor pydantic (:mod:`cyborg.run.launched`)."""
        thin = bool(self.config.text) and all(
            is_thin(self.config, part) for part in [name, *self.hosts.get(name, [])]
        )
        command = [
            self.middleware.python(),
            "-m",
            "cyborg.run.launched" if thin else "cyborg.cli",
            "node",
            name,
            "--config",
            str(self.config_path),
            "--db",
            str(self.data_dir),
            "--seed",
            str(self.seed),
        ]
        if self.config.text:  # validated here: a module's node reads only its own part (cyborg.app.sketch)
            command += ["--checked", text_digest(self.config.text)]
        if self.map_path is not None:
            command += ["--map", str(self.map_path)]
        if name == API:
            command += ["--port", str(self.port)]
        if name == CONTROLLER and fresh:
            command += ["--fresh"]  # a launch is a fresh start: neutral, emotion system on
        command += self.middleware.node_arguments
        for hosted in self.hosts.get(name, []):
            command += ["--with", hosted]
        if self._time_server is not None:
            command += [
                "--lockstep",
                self._time_server.address,
                "--start",
                self.start.isoformat(),
                "--publish-clock" if name == clock_owner else "--no-publish-clock",
            ]
        elif self.speed is not None:
            assert self._epoch_argument is not None
            command += [
                "--speed",
                repr(self.speed),
                "--epoch",
                self._epoch_argument,
                "--start",
                self.start.isoformat(),
                "--publish-clock" if name == clock_owner else "--no-publish-clock",
            ]
        for hosted in self.hosts.get(name, []):  # what the launch tells a part, its host hears
            command += self.extra_args.get(hosted, [])
        return command + self.extra_args.get(name, [])

    def start_all(self) -> None:
        """Prepare the graph, start every part, and with a speed fix the origin once all are ready."""
        if self.lockstep and self.speed is not None:
            raise CyborgError("lockstep time runs as fast as the graph allows: give no speed with it")
        self._graph = self.middleware.launch_graph(self.data_dir, self.say)
        self._rendezvous, self._epoch_argument = self._graph.open(self.speed, lockstep=self.lockstep)
        self.say(f"graph: {self.middleware.graph_name()}")
        if self.speed is not None or self.lockstep:
            self._clock_owner = clock_owner_of(self.config, self.parts)
            self.parts.sort(
                key=lambda name: name != self._clock_owner
            )  # /clock first: the others wait for it
        if self.lockstep:
            self._time_server = TimeServer(set(self.parts), always={self._clock_owner or ""}).start()
        if self.fork and self.zygote is None:
            self.zygote = start_zygote(self.middleware, echo=self.echo)
        for name in self.parts:
            self._spawn(name, fresh=True)
        if self.zygote is not None:
            self.zygote.slim()  # its preloaded copy is memory only it uses now (:mod:`cyborg.run.zygote`)
        nodes = len(self.processes) + sum(len(self.hosts.get(name, [])) for name in self.processes)
        shared = f" in {len(self.processes)} processes" if nodes > len(self.processes) else ""
        self.say(
            f"launched {nodes} nodes{shared}: "
            + ", ".join(
                name + (f" (with {', '.join(self.hosts[name])})" if self.hosts.get(name) else "")
                for name in self.parts
            )
        )
        self.say(self._where_logs_go())
        if self.speed is not None:
            self._start_virtual_time()
        elif self.lockstep:
            self.say(f"virtual time: {self.start.isoformat()}, in lockstep (as fast as every node allows)")

    def _where_logs_go(self) -> str:
        """Where the nodes' lines go: NODE.log each; a shared process's nodes write its first node's."""
        folder = self.middleware.log_file("NODE").parent
        told = f"their warnings and errors show here, prefixed [node]; every log line is in {folder}/NODE.log"
        shared = [(name, hosted) for name, hosted in self.hosts.items() if hosted and name in self.processes]
        for name, hosted in shared:  # one file per process: Python's logging cannot tell its nodes apart
            told += (
                f"; {name}'s process also runs {', '.join(hosted)}: their lines are in {name}.log, "
                f"which their NODE.log links to (their warnings show prefixed [{name}])"
            )
        return told

    def _start_virtual_time(self) -> None:
        assert self._rendezvous is not None and self._graph is not None
        deadline = time.monotonic() + READY_TIMEOUT
        while True:
            ready = self._rendezvous.ready_names()
            waiting = [name for name in self.parts if name not in ready]
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
        self._rendezvous.set_epoch(epoch)
        self._graph.origin_fixed(epoch)
        self.say(
            f"virtual time: {self.start.isoformat()} at speed {self.speed:g}, "
            f"starting at {datetime.fromtimestamp(epoch, UTC):%H:%M:%S.%f} UTC"
        )

    def _spawn(self, name: str, *, fresh: bool) -> subprocess.Popen[bytes] | ForkedNode:
        command = self.command(name, self._clock_owner, fresh=fresh)
        process: subprocess.Popen[bytes] | ForkedNode
        if self.zygote is not None and self.zygote.alive:
            process = self.zygote.spawn(command[3:], module=command[2])  # what follows `python -m MODULE`
        else:
            process = subprocess.Popen(
                command, stdout=None if self.echo else subprocess.DEVNULL, env=self.middleware.environment()
            )
        self.processes[name] = process
        self._started_at[name] = time.monotonic()
        return process

    def supervise(self, ignore: Sequence[str] = ()) -> None:
        """Start again what the graph needs (a master the launch started) and each node that
        stopped (not ``ignore``)."""
        if self._graph is not None:
            self._graph.keep_up()
        now = time.monotonic()
        for name, process in list(self.processes.items()):
            if name in ignore or process.poll() is None:
                continue
            self._check_refused(name, process)
            due = self._respawn_at.get(name)
            if due is None:
                ran = now - self._started_at.get(name, now)
                previous = self._respawn_delay.get(name)
                steady = previous is None or ran >= RESPAWN_STEADY
                delay = RESPAWN_DELAY if previous is None or steady else min(previous * 2, RESPAWN_MAX_DELAY)
                self._respawn_delay[name], self._respawn_at[name] = delay, now + delay
                self.say(
                    f"node {name} stopped ({exit_description(process.returncode)}) after {ran:.1f} s; "
                    f"the robot runs on; starting {name} again in {delay:g} s"
                    + ("" if steady else " (it stopped soon after its last start: see its output above)")
                )
            elif now >= due:
                del self._respawn_at[name]
                started = self._spawn(name, fresh=False)
                resumes = " without --fresh: it resumes the emotion it stored" if name == CONTROLLER else ""
                self.say(f"started node {name} again (pid {started.pid}){resumes}")

    def check_alive(self, ignore: Sequence[str] = ()) -> None:
        """Raise a :class:`CyborgError` naming the nodes that stopped (not ``ignore``)."""
        failed = [n for n, p in self.processes.items() if n not in ignore and p.poll() is not None]
        for name in failed:
            self._check_refused(name, self.processes[name])
        if failed:
            stopped = ", ".join(
                f"{name} ({exit_description(self.processes[name].returncode)})" for name in failed
            )
            raise CyborgError(f"node(s) stopped: {stopped}; the whole robot is stopped too")

    def _check_refused(self, name: str, process: subprocess.Popen[bytes] | ForkedNode) -> None:
        """Raise a :class:`CyborgError` when node ``name`` refused to start: its name is taken."""
        if process.returncode != NAME_TAKEN_EXIT:
            return
        graph = self.middleware.graph_name()
        controller = self.processes.get(CONTROLLER)
        if controller is not None and name != CONTROLLER:
            # Its reason says more (another robot's controller, a leftover parameter home): wait
            # for it, as long as a node takes to look at the graph.
            with contextlib.suppress(subprocess.TimeoutExpired):
                controller.wait(timeout=REFUSAL_GRACE)
        raise CyborgError(
            f"node {name} refused to start: {graph} is taken (the reasons are above: another robot "
            "runs there, a part of this robot was started by hand, or a node was left over); the whole "
            "robot is stopped; fix: stop that robot or node, or give this robot a graph of its own "
            "(ROS 2: ROS_DOMAIN_ID=N, one per robot; ROS 1: ROS_MASTER_URI=http://localhost:PORT; "
            "docs/security.md)"
        )

    def wait(
        self, *, until: str | None = None, timeout: float | None = None, virtual: float | None = None
    ) -> int | None:
        """Until node ``until`` ends (its exit code), ``timeout`` real seconds pass, ``virtual``
        seconds of lockstep time pass, or (without ``respawn``) another node stops (an error)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            if until is not None and self.processes[until].poll() is not None:
                return self.processes[until].returncode
            server = self._time_server
            if virtual is not None and server is not None and server.time_ns >= virtual * NS:
                return None
            if self.respawn:
                self.supervise(ignore=[until] if until else [])
            else:
                self.check_alive(ignore=[until] if until else [])
            if deadline is not None and time.monotonic() > deadline:
                return None
            self._pause(deadline)

    def _pause(self, deadline: float | None) -> None:
        """Until the next look at the nodes: 0.1 s, or up to IDLE_LOOK s while every node is the
        zygote's, which tells each one's end at once (10 looks a second were the idle launcher's
        whole work)."""
        zygote = self.zygote
        if (
            zygote is None
            or not zygote.alive
            or self._time_server is not None
            or self._respawn_at
            or not all(isinstance(process, ForkedNode) for process in self.processes.values())
        ):
            time.sleep(0.1)
            return
        wait = IDLE_LOOK if deadline is None else max(0.0, min(IDLE_LOOK, deadline - time.monotonic()))
        zygote.ended.wait(wait)
        zygote.ended.clear()  # (before the next look: an end told meanwhile is seen by it)

    def stop_all(self) -> None:
        """SIGINT every node (killed after 10 s), then put the graph back as it was."""
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
        finally:
            if self.zygote is not None:
                self.zygote.close()
                self.zygote = None
            if self._time_server is not None:
                server = self._time_server
                server.close()
                self.say(
                    f"lockstep: {server.time_ns / NS:.1f} virtual s in {server.grants} grants "
                    f"({server.deltas} of them delta cycles); nodes woken most: "
                    + ", ".join(f"{name} {count}" for name, count in server.woken.most_common(4))
                    + (f"; written off: {dict(server.written_off)}" if server.written_off else "")
                    + (
                        f"; not lockstepped: {', '.join(sorted(server.foreign_seen))}"
                        if server.foreign_seen
                        else ""
                    )
                )
            if self._graph is not None:
                self._graph.close()


def launch(robot: Launch, *, duration: float | None = None) -> None:
    """Run ``robot`` (respawning its nodes) until SIGINT/SIGTERM or ``duration`` seconds
    (virtual with a speed), then stop it."""

    def stop_on_term(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop_on_term)  # `kill` and `timeout` stop the nodes too
    # Ctrl-C stops the robot even when the launch inherited SIGINT ignored (a script's background
    # job, nohup): Python then leaves it ignored, and the launch could only be killed.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    robot.respawn = True
    try:
        robot.start_all()
        if robot.lockstep:
            robot.wait(virtual=duration)
        else:
            robot.wait(timeout=None if duration is None else duration / (robot.speed or 1.0))
    except KeyboardInterrupt:
        click.echo("stopping")
    finally:
        robot.stop_all()
