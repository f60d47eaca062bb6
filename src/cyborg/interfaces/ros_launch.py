"""``cyborg launch`` and ``cyborg sim --ros``: the whole robot as ROS nodes, one process per part.

A master is started when none answers at ``ROS_MASTER_URI``; each part runs as ``cyborg node NAME``
(:mod:`cyborg.interfaces.ros_commands`). With a speed, the launch sets ``/use_sim_time`` and
fixes the shared origin of virtual time once every node is ready. ``cyborg sim --ros --script
FILE`` adds the ``cyborg_scenario`` node, which plays the script and writes the transcript.

With ``--ros2`` the parts are ROS 2 nodes (``cyborg node NAME --ros2``, in ``.venv-ros2``'s
Python): no master, no ``/use_sim_time`` parameter (each node sets its own ``use_sim_time``),
and the nodes meet the launch in a folder of its own to agree on the origin.

``cyborg launch`` keeps the robot running when a node stops: it says so and starts that node again
(as roslaunch's ``respawn``), after RESPAWN_DELAY seconds, doubled for each stop within
RESPAWN_STEADY seconds of its start, up to RESPAWN_MAX_DELAY. The controller comes back without
``--fresh``, so it resumes the emotion it stored. A roscore the launch started is started again on
its port; every node registers again with it (:mod:`cyborg.transport.ros`).
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.parse
import uuid
import xml.sax.saxutils
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import click

from cyborg.app.config import LoadedConfig
from cyborg.app.parts import API, CONTROLLER, NodeContext, build_part, part_names
from cyborg.errors import CyborgError
from cyborg.interfaces.ros2_env import ros2_environment, ros2_python
from cyborg.interfaces.ros_commands import (
    EPOCH_DIR_PREFIX,
    EPOCH_MARGIN,
    EPOCH_PARAM_PREFIX,
    READY_TIMEOUT,
    SCENARIO,
    SIM_PARAMS,
    USE_SIM_TIME,
    FolderRendezvous,
    Master,
    MasterRendezvous,
    Rendezvous,
    clock_owner_of,
    master_running,
    master_uri,
    node_log_file,
    require_ros,
)
from cyborg.sim.script import Script
from cyborg.transport.clock import DEFAULT_VIRTUAL_START, VirtualClock

RESPAWN_DELAY = 1.0  # seconds before a stopped node is started again
RESPAWN_STEADY = 10.0  # a node that ran this long before it stopped is started again after RESPAWN_DELAY
RESPAWN_MAX_DELAY = 30.0  # a node stopping again and again waits at most this long


def _how(code: int | None) -> str:
    if code is not None and code < 0:
        with contextlib.suppress(ValueError):
            return f"killed by {signal.Signals(-code).name}"
    return f"exit code {code}"


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
    With ``respawn``: once started, a node that stops is started again (see the module's doc).
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
    respawn: bool = False
    ros2: bool = False
    _namespace: str | None = None
    _rendezvous: Rendezvous | None = None
    _run_dir: Path | None = None
    _clock_owner: str | None = None
    _epoch: float | None = None
    _started_at: dict[str, float] = field(default_factory=dict)
    _respawn_delay: dict[str, float] = field(default_factory=dict)
    _respawn_at: dict[str, float] = field(default_factory=dict)
    _saved_sim_time: Any = None
    _touched_sim_time: bool = False

    def command(self, name: str, clock_owner: str | None, *, fresh: bool = True) -> list[str]:
        command = [
            ros2_python() if self.ros2 else sys.executable,
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
        if name == CONTROLLER and fresh:
            command += ["--fresh"]  # a launch is a fresh start: neutral, emotion system on
        if self.ros2:
            command += ["--ros2"]
        if self.speed is not None:
            command += [
                "--speed",
                repr(self.speed),
                "--epoch",
                EPOCH_DIR_PREFIX + str(self._run_dir)
                if self.ros2
                else EPOCH_PARAM_PREFIX + str(self._namespace),
                "--start",
                self.start.isoformat(),
                "--publish-clock" if name == clock_owner else "--no-publish-clock",
            ]
        return command + self.extra_args.get(name, [])

    def start_all(self) -> None:
        if self.ros2:
            self._start_all_ros2()
            return
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
            self._rendezvous = MasterRendezvous(self._namespace)
            clock_owner = clock_owner_of(self.config, self.parts)
            self.parts.sort(key=lambda name: name != clock_owner)  # /clock first: the others wait for it
            master.set(USE_SIM_TIME, True)
            self._touched_sim_time = True
        elif self._saved_sim_time:
            master.set(USE_SIM_TIME, False)  # left over from a simulated run: nodes would wait for /clock
            self._touched_sim_time = True
        self._clock_owner = clock_owner
        self._spawn_all()

    def _start_all_ros2(self) -> None:
        """ROS 2: no master to start or ask; virtual time's origin is set in a folder of this run."""
        ros2_python()  # says how to install ROS 2 when it is not
        if self.speed is not None:
            self._run_dir = Path(tempfile.mkdtemp(prefix="cyborg-launch-"))
            self._rendezvous = FolderRendezvous(self._run_dir)
            self._clock_owner = clock_owner_of(self.config, self.parts)
            self.parts.sort(key=lambda name: name != self._clock_owner)  # /clock first
        self._spawn_all()

    def _spawn_all(self) -> None:
        for name in self.parts:
            self._spawn(name, fresh=True)
        self.say(f"launched {len(self.processes)} nodes: {', '.join(self.parts)}")
        self.say(
            f"their warnings and errors show here, prefixed [node]; every log line is in "
            f"{node_log_file('NODE', ros2=self.ros2).parent}/NODE.log"
        )
        if self.speed is not None:
            self._start_virtual_time()

    def _start_virtual_time(self) -> None:
        assert self._rendezvous is not None
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
        epoch = self._epoch = time.time() + EPOCH_MARGIN
        self._rendezvous.set_epoch(epoch)
        self.say(
            f"virtual time: {self.start.isoformat()} at speed {self.speed:g}, "
            f"starting at {datetime.fromtimestamp(epoch, UTC):%H:%M:%S.%f} UTC"
        )

    def _spawn(self, name: str, *, fresh: bool) -> subprocess.Popen[bytes]:
        process = subprocess.Popen(
            self.command(name, self._clock_owner, fresh=fresh),
            stdout=None if self.echo else subprocess.DEVNULL,
            env=ros2_environment() if self.ros2 else None,
        )
        self.processes[name] = process
        self._started_at[name] = time.monotonic()
        return process

    def supervise(self, ignore: Sequence[str] = ()) -> None:
        """Start again the master this launch started and each node that stopped (not ``ignore``)."""
        if self.master is not None and self.master.poll() is not None and not master_running():
            self._restart_master()  # (roscore alone gone while its rosmaster answers: nothing to do)
        now = time.monotonic()
        for name, process in list(self.processes.items()):
            if name in ignore or process.poll() is None:
                continue
            due = self._respawn_at.get(name)
            if due is None:
                ran = now - self._started_at.get(name, now)
                previous = self._respawn_delay.get(name)
                steady = previous is None or ran >= RESPAWN_STEADY
                delay = RESPAWN_DELAY if previous is None or steady else min(previous * 2, RESPAWN_MAX_DELAY)
                self._respawn_delay[name], self._respawn_at[name] = delay, now + delay
                self.say(
                    f"node {name} stopped ({_how(process.returncode)}) after {ran:.1f} s; the robot runs "
                    f"on; starting {name} again in {delay:g} s"
                    + ("" if steady else " (it stopped soon after its last start: see its output above)")
                )
            elif now >= due:
                del self._respawn_at[name]
                started = self._spawn(name, fresh=False)
                resumes = " without --fresh: it resumes the emotion it stored" if name == CONTROLLER else ""
                self.say(f"started node {name} again (pid {started.pid}){resumes}")

    def _restart_master(self) -> None:
        assert self.master is not None
        port = urllib.parse.urlparse(master_uri()).port or 11311
        self.say(
            f"roscore stopped ({_how(self.master.returncode)}); starting it again at {master_uri()}; "
            "the nodes register again by themselves"
        )
        self.master = start_master(port, self.data_dir / "ros")
        master = Master()
        if self.speed is not None:  # a new master holds no parameters: ours again, for nodes started later
            master.set(USE_SIM_TIME, True)
            if self._epoch is not None:
                master.set(f"{self._namespace}/epoch", self._epoch)

    def check_alive(self, ignore: Sequence[str] = ()) -> None:
        failed = [n for n, p in self.processes.items() if n not in ignore and p.poll() is not None]
        if failed:
            raise CyborgError(f"node(s) stopped: {', '.join(failed)}; the whole robot is stopped too")

    def wait(self, *, until: str | None = None, timeout: float | None = None) -> int | None:
        """Until node ``until`` ends (its exit code), ``timeout`` real seconds pass or (without
        ``respawn``) another node stops (an error)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            if until is not None and self.processes[until].poll() is not None:
                return self.processes[until].returncode
            if self.respawn:
                self.supervise(ignore=[until] if until else [])
            else:
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
            if self._run_dir is not None:
                shutil.rmtree(self._run_dir, ignore_errors=True)
            if self.master is None and not self.ros2 and master_running():
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
    ros2: bool = False,
) -> None:
    """Start a master if needed, then every part as its own `cyborg node` process, until stopped.

    ``duration``: stop after that many seconds (virtual with a speed). ``ros2``: ROS 2 nodes, no master.
    """

    def stop_on_term(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop_on_term)  # `kill` and `timeout` stop the nodes too
    # Ctrl-C stops the robot even when the launch inherited SIGINT ignored (a script's background
    # job, nohup): Python then leaves it ignored, and the launch could only be killed.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    robot = Launch(
        config_path,
        config,
        list(parts),
        data_dir,
        map_path,
        port,
        echo,
        speed=speed,
        start=start,
        respawn=True,
        ros2=ros2,
    )
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
    speed: float,
    data_dir: Path | None,
    map_path: Path | None,
    echo: bool = False,
    say: Callable[[str], None] = click.echo,
    ros2: bool = False,
) -> list[dict[str, Any]]:
    """Run a scenario over ROS (``ros2``: ROS 2): the robot's nodes (no API) plus ``cyborg_scenario``;
    return the records."""
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
            ros2=ros2,
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
        fresh = " --fresh" if name == CONTROLLER else ""
        args = xml.sax.saxutils.quoteattr(f"node {name} --config {config_path} --db {data_dir}{fresh}")
        lines.append(
            f'  <node name="{name}" pkg="cyborg_controller" type="cyborg" args={args} required="true" output="screen"/>'
        )
    lines.append("</launch>")
    return "\n".join(lines) + "\n"


def all_parts(config: LoadedConfig) -> list[str]:
    return part_names(config)
