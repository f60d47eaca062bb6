"""Issue 12, item 3: the robot lives through a restart of its ROS master and through a dead node.

The master test runs its own roscore on a port of its own (the session's master, which this
pytest process is registered with, stays untouched), kills it with SIGKILL mid-run and starts it
again on the same port. Everything in it is observed from outside, as a user would: the master's
list of nodes (what ``rosnode list`` prints), its parameters, and ``ros_probe.py`` nodes that send
events and hear state changes. The launch test runs ``cyborg launch`` on the session's master and
kills its nodes.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import IO, Any

from actionlib_msgs.msg import GoalStatus, GoalStatusArray  # type: ignore[import-not-found]

from tests.support.ros import (
    NodeProcess,
    Observers,
    Processes,
    free_port,
    master_answers,
    xmlrpc_server,
    yaml_path,
)
from tests.support.wait import wait_for

HERE = Path(__file__).resolve().parent
PROBE = HERE / "ros_probe.py"
OUTAGE = yaml_path("outage.yaml")
FAULTS = yaml_path("faults.yaml")
OUTAGE_NODES = (
    "cyborg_test_idle",
    "cyborg_test_worker",
    "cyborg_test_speech_gatekeeper",
    "cyborg_controller",
)
CALLER = "/cyborg_tests"


def master_value(uri: str, method: str, *args: Any) -> Any:
    code, message, value = getattr(xmlrpc_server(uri), method)(CALLER, *args)
    assert code == 1, f"{method}{args} at {uri}: {message}"
    return value


def listed_nodes(uri: str) -> set[str]:
    """What ``rosnode list`` prints: every node the master has a registration of."""
    try:
        state = master_value(uri, "getSystemState")
    except OSError:
        return set()
    return {node for kind in state for _, nodes in kind for node in nodes}


def param(uri: str, key: str) -> Any:
    code, _, value = xmlrpc_server(uri).getParam(CALLER, key)
    return value if code == 1 else None


def node_pid(uri: str, node: str) -> int | None:
    """The pid of ``node`` as the node itself reports it (None if the master does not list it)."""
    code, _, api = xmlrpc_server(uri).lookupNode(CALLER, node)
    if code != 1:
        return None
    try:
        _, _, pid = xmlrpc_server(api).getPid(CALLER)
    except OSError:
        return None  # listed, but gone
    return int(pid)


def children(pid: int) -> list[int]:
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue  # ended meanwhile
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def program(pid: int) -> str:
    """The name of the program a process runs (``roscore`` for ``python3 /usr/bin/roscore ...``)."""
    words = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    script = words[1] if len(words) > 1 and words[0].endswith(b"python3") else words[0]
    return Path(script.decode()).name


class Probe:
    """A ``ros_probe.py`` node: ``send`` an event, wait for a ``state FROM EVENT TO`` line."""

    def __init__(self, name: str, env: dict[str, str], log: IO[bytes]) -> None:
        self.name = name
        self.lines: list[str] = []
        self._condition = threading.Condition()
        self.process = subprocess.Popen(
            [sys.executable, str(PROBE), name],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=log,
            env={**env, "PYTHONUNBUFFERED": "1"},
            text=True,
        )
        threading.Thread(target=self._read, name=f"probe {name}", daemon=True).start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            with self._condition:
                self.lines.append(line.strip())
                self._condition.notify_all()
        with self._condition:
            self.lines.append("<ended>")
            self._condition.notify_all()

    def mark(self) -> int:
        with self._condition:
            return len(self.lines)

    def wait_line(self, line: str, *, after: int = 0, timeout: float = 10.0) -> float:
        """Wait for ``line`` after index ``after``; returns time.monotonic() when it was read."""
        deadline = time.monotonic() + timeout
        with self._condition:
            while line not in self.lines[after:]:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or "<ended>" in self.lines:
                    raise AssertionError(
                        f"probe {self.name}: no {line!r} within {timeout} s; got {self.lines}"
                    )
                self._condition.wait(remaining)
        return time.monotonic()

    def send(self, event: str) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(f"send {event}\n")
        self.process.stdin.flush()

    def close(self) -> None:
        if self.process.stdin is not None:
            self.process.stdin.close()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait(timeout=5)


class PrivateMaster:
    """A roscore of this test's own on a fixed port: killed and started again on that port."""

    def __init__(self, processes: Processes) -> None:
        self.processes = processes
        self.port = free_port()
        self.uri = f"http://localhost:{self.port}"
        self.env = {**os.environ, "ROS_MASTER_URI": self.uri}
        self.core: NodeProcess | None = None

    def start(self) -> None:
        self.core = self.processes.start(
            "roscore",
            ["roscore", "-p", str(self.port)],
            "started core service",
            env=self.env,
            new_session=True,
        )
        wait_for(lambda: master_answers(self.uri), timeout=30, what=f"roscore answering at {self.uri}")

    def kill(self) -> None:
        """SIGKILL to roscore, rosmaster and rosout at once: no goodbye to anyone. (roscore starts
        rosmaster and rosout in sessions of their own, so they are found as its children.)"""
        assert self.core is not None
        for pid in [self.core.pid, *children(self.core.pid)]:
            os.kill(pid, signal.SIGKILL)
        self.core.process.wait(timeout=10)
        wait_for(lambda: not master_answers(self.uri), timeout=10, what="the master gone")


def test_a_master_restart_keeps_the_robot_running_and_every_node_registers_again(
    processes: Processes, tmp_path: Path
) -> None:
    master = PrivateMaster(processes)
    master.start()
    nodes = {name: processes.cyborg_node(name, OUTAGE, tmp_path, env=master.env) for name in OUTAGE_NODES}
    processes.wait_ready(*nodes.values(), timeout=60)
    controller = nodes["cyborg_controller"]
    probe_log = (tmp_path / "probes.log").open("wb")
    probes: list[Probe] = []
    try:
        before = Probe("cyborg_test_probe_before", master.env, probe_log)
        probes.append(before)
        before.wait_line("ready", timeout=30)
        before.send("work")  # both modules' action servers connected before the outage
        before.wait_line("state idle work working")
        mark = before.mark()
        before.send("rest")
        before.wait_line("state working rest idle", after=mark)

        master.kill()
        # State changes while the master is away: the connections made already carry them; a
        # module the controller never reached is out of reach now, so it takes 'aborted'.
        mark = before.mark()
        before.send("nap")
        before.wait_line("state idle nap napping", after=mark)
        before.wait_line("state napping aborted idle", after=mark, timeout=15)
        mark = before.mark()
        before.send("work")
        before.wait_line("state idle work working", after=mark)
        wait_for(
            lambda: "does not answer" in controller.log(),
            timeout=10,
            what="the controller logging the outage",
        )
        assert controller.process.poll() is None

        restarted = time.monotonic()
        master.start()
        answered = time.monotonic()
        expected = {f"/{name}" for name in OUTAGE_NODES}
        wait_for(
            lambda: expected <= listed_nodes(master.uri),
            timeout=15,
            what=f"every node listed again: {sorted(expected)}",
        )
        listed = time.monotonic()
        # The parameter set during the outage reaches the new master: the gatekeeper reads the right one.
        wait_for(
            lambda: param(master.uri, "/state_resources") == {"speech": "cyborg_test_worker"},
            timeout=10,
            what="/state_resources of 'working' on the new master",
        )
        # A node that joins now finds the controller through the new master, both ways.
        after = Probe("cyborg_test_probe_after", master.env, probe_log)
        probes.append(after)
        after.wait_line("ready", timeout=30)
        assert after.lines[0] == "state idle work working"  # the controller's latched state
        mark = after.mark()
        after.send("rest")
        changed = after.wait_line("state working rest idle", after=mark)
        assert param(master.uri, "/state_resources") == {"speech": "cyborg_test_idle"}
        assert param(master.uri, "/cyborg_controller/emotion_enabled") is True
        print(
            f"\nmaster restart: roscore answered {answered - restarted:.2f} s after it was started; "
            f"every node listed {listed - answered:.2f} s after that; a state change end to end "
            f"(a new node's event, through the new master) {changed - answered:.2f} s after it answered, "
            f"{changed - restarted:.2f} s after roscore was started"
        )
    finally:
        for probe in probes:
            probe.close()
        probe_log.close()
    outage_lines = [line for line in controller.log().splitlines() if "does not answer" in line]
    assert len(outage_lines) == 1, outage_lines  # logged once, not once per attempt
    assert "is back" in controller.log()
    for node in nodes.values():
        assert node.process.poll() is None, f"{node.name} stopped:\n{node.log()[-2000:]}"


def _has_status(heard: Any, status: int) -> bool:
    return any(s.status == status for s in heard.message.status_list)


def test_launch_restarts_a_killed_node_and_the_robot_keeps_running(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    uri = os.environ["ROS_MASTER_URI"]  # the session's master: cyborg launch uses the one running
    changes = observe.state_changes()
    worker_status = observe.topic("/cyborg_test_worker/work/status", GoalStatusArray)
    parts = ("cyborg_controller", "cyborg_test_idle", "cyborg_test_worker")
    only = [arg for part in parts for arg in ("--only", part)]
    command = [sys.executable, "-m", "cyborg.cli", "launch", "--config", str(FAULTS)]
    ros_home = tmp_path / "ros_home"  # the nodes' ROS logs (rospy's log file takes our log lines)
    launch = processes.start(
        "cyborg_launch",
        [*command, "--db", str(tmp_path), *only],
        "launched 3 nodes",
        env={**os.environ, "ROS_HOME": str(ros_home)},
        new_session=True,
    )
    processes.wait_ready(launch)
    changes.wait_state("idle", event="start", timeout=60)

    wait_for(lambda: node_pid(uri, "/cyborg_test_worker"), timeout=60, what="the worker registered")
    # killed only once it serves its action: a worker killed earlier never says it runs, and the
    # count of "running" lines below would then wait for a second line that cannot come
    wait_for(lambda: "node cyborg_test_worker running" in launch.log(), timeout=60, what="the worker running")
    worker = node_pid(uri, "/cyborg_test_worker")
    assert worker is not None
    os.kill(worker, signal.SIGKILL)
    wait_for(
        lambda: node_pid(uri, "/cyborg_test_worker") not in (None, worker),
        timeout=30,
        what="the worker started again",
    )
    assert launch.process.poll() is None, launch.log()[-3000:]
    assert "node cyborg_test_worker stopped" in launch.log()
    wait_for(
        lambda: launch.log().count("node cyborg_test_worker running") == 2,
        timeout=60,
        what="the restarted worker serving its action",
    )
    events = observe.events()
    events.wait_connected()
    mark = changes.mark()
    events.send("work")
    change = changes.wait_state("working", event="work", after=mark, timeout=20)
    worker_status.wait_for(
        lambda h: h.at > change.at and _has_status(h, GoalStatus.ACTIVE),
        timeout=10,
        what="the restarted worker's goal ACTIVE",
    )

    # The controller comes back without --fresh: it resumes the emotion it stored a moment ago.
    controller = node_pid(uri, "/cyborg_controller")
    assert controller is not None
    mark = changes.mark()
    os.kill(controller, signal.SIGKILL)
    change = changes.wait_state("idle", event="start", after=mark, timeout=60)
    assert change.message.from_system_state == ""
    assert "started node cyborg_controller again" in launch.log()
    controller_log = (ros_home / "log" / "cyborg_controller.log").read_text()
    assert "the emotion system starts neutral and on: a fresh start" in controller_log  # the launch
    assert "resumed the stored emotion neutral" in controller_log  # the restart
    assert launch.process.poll() is None
    assert node_pid(uri, "/cyborg_test_idle") is not None


def test_launch_starts_its_roscore_again_and_the_robot_works_through_the_new_one(
    processes: Processes, tmp_path: Path
) -> None:
    port = free_port()
    uri = f"http://localhost:{port}"
    env = {**os.environ, "ROS_MASTER_URI": uri, "ROS_HOME": str(tmp_path / "ros_home")}
    parts = ("cyborg_controller", "cyborg_test_idle", "cyborg_test_worker")
    only = [arg for part in parts for arg in ("--only", part)]
    command = [sys.executable, "-m", "cyborg.cli", "launch", "--config", str(FAULTS)]
    launch = processes.start(
        "cyborg_launch",
        [*command, "--db", str(tmp_path), *only],
        "launched 3 nodes",
        env=env,
        new_session=True,
    )
    processes.wait_ready(launch, timeout=60)
    assert f"started roscore at {uri}" in launch.log()
    expected = {f"/{part}" for part in parts}
    wait_for(
        lambda: all(f"node {part} running" in launch.log() for part in parts),
        timeout=60,
        what="every node running",
    )
    roscore = [pid for pid in children(launch.pid) if program(pid) == "roscore"]
    assert len(roscore) == 1, roscore
    for pid in [*roscore, *children(roscore[0])]:
        os.kill(pid, signal.SIGKILL)
    killed = time.monotonic()
    wait_for(lambda: "starting it again" in launch.log(), timeout=10, what="the launch noticing")
    wait_for(lambda: expected <= listed_nodes(uri), timeout=30, what="every node listed again")
    listed = time.monotonic()
    with (tmp_path / "probe.log").open("wb") as probe_log:
        probe = Probe("cyborg_test_probe", env, probe_log)
        try:
            probe.wait_line("ready", timeout=30)
            mark = probe.mark()
            probe.send("work")
            changed = probe.wait_line("state idle work working", after=mark)
        finally:
            probe.close()
    assert launch.process.poll() is None
    assert " stopped (" not in launch.log().split("starting it again", 1)[1]  # no node stopped
    print(
        f"\nroscore of cyborg launch killed: every node listed {listed - killed:.2f} s later, "
        f"a state change end to end {changed - killed:.2f} s later"
    )


def test_launch_shows_each_nodes_warnings_in_its_terminal_and_says_where_the_logs_are(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    """A state whose module is not running: the controller's reason shows in the launch's own output."""
    changes = observe.state_changes()
    parts = ("cyborg_controller", "cyborg_test_idle")  # no worker: 'working' has no action server
    only = [arg for part in parts for arg in ("--only", part)]
    ros_home = tmp_path / "ros_home"
    launch = processes.start(
        "cyborg_launch",
        [
            sys.executable,
            "-m",
            "cyborg.cli",
            "launch",
            "--config",
            str(FAULTS),
            "--db",
            str(tmp_path),
            *only,
        ],
        "launched 2 nodes",
        env={**os.environ, "ROS_HOME": str(ros_home)},
        new_session=True,
    )
    processes.wait_ready(launch)
    changes.wait_state("idle", event="start", timeout=60)
    assert f"every log line is in {ros_home / 'log'}/NODE.log" in launch.log()
    events = observe.events()
    events.wait_connected()
    mark = changes.mark()
    events.send("work")
    changes.wait_state("recovering", event="aborted", after=mark, timeout=30)
    wait_for(
        lambda: (
            "[cyborg_controller] WARNING cyborg.controller.runtime: no action server cyborg_test_worker/work"
            in launch.log()
        ),
        timeout=10,
        what="the controller's warning in the launch's terminal",
    )
    assert "[cyborg_test_idle] INFO" not in launch.log(), "only warnings and errors"
    assert "no action server" in (ros_home / "log" / "cyborg_controller.log").read_text()
