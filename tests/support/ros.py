"""ROS 1 test support: a real roscore for the session, `cyborg node` processes, topic recorders.

One roscore serves the whole pytest session: rospy allows one ``init_node`` per process,
so the pytest process (node ``/cyborg_contract``, one :class:`RosTransport` shared by the
contract tests and the tests in tests/ros) can only ever talk to one master. Whoever needs
ROS first starts it through :func:`ros_session` (tests/ros/conftest.py's ``ros`` fixture,
tests/transport/test_contract.py's ``ros`` graph), and it is stopped when pytest unconfigures.

The environment comes from ``.venv/ros/setup.sh`` (written by scripts/install-ros):
ROS_PACKAGE_PATH and PYTHONPATH, so /usr/bin/ros* tools and a /usr/bin/python3 third-party
module find our message types; ROS_MASTER_URI points at the session's master on a free
port and ROS_HOSTNAME is ``localhost``. These are set in ``os.environ``, so every child
process (roscore, ``cyborg node``, scripts) inherits them.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import xmlrpc.client
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

ROS_TESTS = Path(__file__).resolve().parents[1] / "ros"  # the machines and modules of tests/ros
SETUP_SH = Path(sys.prefix) / "ros" / "setup.sh"
ROS_VARIABLES = ("ROS_PACKAGE_PATH", "PYTHONPATH")
PROCESS_NODE = "cyborg_contract"  # this pytest process's ROS node name
_SESSION_ATTRIBUTE = "_cyborg_ros_session"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def sourced_environment(setup_sh: Path, base: dict[str, str]) -> dict[str, str]:
    """The variables ``setup_sh`` exports when sourced on top of ``base``."""
    if not setup_sh.is_file():
        raise RuntimeError(
            f"{setup_sh} is missing: ROS is not wired into this venv; fix: run scripts/setup --test "
            "(it runs scripts/install-ros)"
        )
    out = subprocess.run(
        ["bash", "-c", 'set -e; . "$1"; env -0', "bash", str(setup_sh)],
        env=base,
        check=True,
        capture_output=True,
    ).stdout
    pairs = (entry.split("=", 1) for entry in out.decode().split("\0") if "=" in entry)
    return dict(pairs)


def xmlrpc_server(uri: str) -> Any:
    """An XML-RPC server (a ROS master or node) at ``uri``; its answers are untyped."""
    return xmlrpc.client.ServerProxy(uri)


def master_answers(uri: str) -> bool:
    try:
        code, _, state = xmlrpc_server(uri).getSystemState("/cyborg_tests")
    except (OSError, xmlrpc.client.Error):
        return False
    return code == 1 and any(node == "/rosout" for _, nodes in state[0] for node in nodes)


def stop_process(
    process: subprocess.Popen[Any], *, first: int = signal.SIGINT, grace: float = 5.0, group: bool = False
) -> None:
    """Stop one process we started, by pid; ``group``: it leads its own process group (start_new_session),
    whose leftovers (roscore's rosmaster and rosout) are killed too."""
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            process.send_signal(first)
        try:
            process.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                process.kill()
            process.wait(timeout=5)
    if group:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, signal.SIGKILL)


class RosMaster:
    """``roscore -p PORT`` with a temporary ROS_HOME; sets the ROS variables in ``os.environ``."""

    def __init__(self) -> None:
        self.port = free_port()
        self.uri = f"http://localhost:{self.port}"
        self.home = Path(tempfile.mkdtemp(prefix="cyborg-ros-home-"))
        self.log_path = self.home / "roscore.log"
        self._saved: dict[str, str | None] = {}
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        base = {k: v for k, v in os.environ.items() if k not in ("ROS_IP", "ROS_MASTER_URI")}
        base["ROS_HOSTNAME"] = "localhost"
        sourced = sourced_environment(SETUP_SH, base)
        values = {name: sourced[name] for name in ROS_VARIABLES}
        values.update(ROS_MASTER_URI=self.uri, ROS_HOSTNAME="localhost", ROS_HOME=str(self.home))
        for name in (*values, "ROS_IP"):
            self._saved[name] = os.environ.get(name)
        os.environ.pop("ROS_IP", None)
        os.environ.update(values)
        with self.log_path.open("wb") as log:
            self.process = subprocess.Popen(
                ["roscore", "-p", str(self.port)],
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,  # its own group: rosmaster and rosout go with it
            )
        deadline = time.monotonic() + 30
        while not master_answers(self.uri):
            if self.process.poll() is not None or time.monotonic() > deadline:
                log_text = self.log_path.read_text(errors="replace")[-2000:]
                self.stop()
                raise RuntimeError(f"roscore -p {self.port} did not come up; its log:\n{log_text}")
            time.sleep(0.05)

    def stop(self) -> None:
        try:
            if self.process is not None:
                stop_process(self.process, grace=10.0, group=True)
        finally:
            for name, value in self._saved.items():
                if value is None:
                    os.environ.pop(name, None)
                else:
                    os.environ[name] = value
            self._saved.clear()
            shutil.rmtree(self.home, ignore_errors=True)


class RosSession:
    """The session's master and this process's ROS transport (node ``/cyborg_contract``)."""

    def __init__(self) -> None:
        for attempt in range(3):  # the free port may be taken meanwhile (tests run side by side)
            self.master = RosMaster()
            try:
                self.master.start()
                break
            except RuntimeError:
                if attempt == 2:
                    raise
        try:
            from cyborg.transport.clock import RealClock
            from cyborg.transport.ros import RosTransport

            self.clock = RealClock()
            self.transport = RosTransport(self.clock, process_name=PROCESS_NODE)
            self.transport.node("cyborg_test_session")  # rospy.init_node happens here, once
        except BaseException:
            self.master.stop()
            raise

    def close(self) -> None:
        import rospy  # type: ignore[import-not-found]

        try:
            self.transport.shutdown()
            rospy.signal_shutdown("tests done")
            self.clock.close()
        finally:
            self.master.stop()


def ros_session(config: pytest.Config) -> RosSession:
    """The session's :class:`RosSession`, started on first use, stopped when pytest ends."""
    session: RosSession | None = getattr(config, _SESSION_ATTRIBUTE, None)
    if session is None:
        session = RosSession()
        setattr(config, _SESSION_ATTRIBUTE, session)
        config.add_cleanup(session.close)
    return session


# --- processes --------------------------------------------------------------------------------


@dataclass
class NodeProcess:
    """A child process whose stderr (and stdout) go to a log file."""

    name: str
    process: subprocess.Popen[bytes]
    log_path: Path
    ready_line: str
    own_group: bool = False  # started in a new session: stopping kills its whole process group

    @property
    def pid(self) -> int:
        return self.process.pid

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def is_ready(self) -> bool:
        return self.ready_line in self.log()

    def kill(self) -> None:
        """SIGKILL: the process gets no chance to unregister or say goodbye."""
        self.process.kill()
        self.process.wait(timeout=5)

    def stop(self) -> None:
        stop_process(self.process, group=self.own_group)


@dataclass
class Processes:
    """Starts `cyborg node` processes and scripts; stops every one of them at teardown."""

    log_dir: Path
    started: list[NodeProcess] = field(default_factory=list)

    def start(
        self,
        name: str,
        command: Sequence[str],
        ready_line: str,
        *,
        env: dict[str, str] | None = None,
        new_session: bool = False,
    ) -> NodeProcess:
        """Start ``command``; ready once its output holds ``ready_line``. ``new_session``: for
        programs with children of their own (roscore), which are then stopped with it."""
        log_path = self.log_dir / f"{name}-{len(self.started)}.log"
        with log_path.open("wb") as log:
            process = subprocess.Popen(
                list(command),
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                env={**(env if env is not None else os.environ), "PYTHONUNBUFFERED": "1"},
                start_new_session=new_session,
            )
        node = NodeProcess(name, process, log_path, ready_line, own_group=new_session)
        self.started.append(node)
        return node

    def cyborg_node(
        self,
        name: str,
        config: Path,
        db: Path,
        *extra: str,
        prefix: Sequence[str] = (),
        env: dict[str, str] | None = None,
    ) -> NodeProcess:
        """``cyborg node NAME --config FILE --db DIR``; ready once it logs ``node NAME running``.
        ``prefix``: a command to run it under (``ip netns exec NS``)."""
        command = [sys.executable, "-m", "cyborg.cli", "node", name, "--config", str(config)]
        return self.start(name, [*prefix, *command, "--db", str(db), *extra], f"node {name} running", env=env)

    def wait_ready(self, *nodes: NodeProcess, timeout: float = 90.0) -> None:
        deadline = time.monotonic() + timeout
        for node in nodes:
            while not node.is_ready():
                if node.process.poll() is not None:
                    raise AssertionError(
                        f"{node.name} exited ({node.process.returncode}) before it was ready; "
                        f"its log:\n{node.log()[-3000:]}"
                    )
                if time.monotonic() > deadline:
                    raise AssertionError(
                        f"{node.name} not ready within {timeout} s; log:\n{node.log()[-3000:]}"
                    )
                time.sleep(0.02)

    def stop_all(self) -> None:
        """SIGINT to all at once, then wait for each (SIGKILL after a grace period)."""
        for node in self.started:
            if node.process.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    node.process.send_signal(signal.SIGINT)
        errors: list[BaseException] = []
        for node in reversed(self.started):
            try:
                node.stop()
            except BaseException as exc:  # stop the others anyway
                errors.append(exc)
        if errors:
            raise errors[0]

    def logs(self) -> str:
        return "\n".join(f"--- {n.name} (pid {n.pid}) ---\n{n.log()[-2500:]}" for n in self.started)


# --- observing the graph from this process (plain rospy, as the stock tools do) ----------------


@dataclass(frozen=True)
class Heard:
    message: Any
    sender: str  # the publishing node, from the connection header
    at: float  # time.monotonic() on arrival


class TopicRecorder:
    """Records every message on one topic with its sender; waits for messages."""

    def __init__(self, topic: str, msg_class: Any) -> None:
        import rospy

        self.topic = topic
        self.heard: list[Heard] = []
        self._condition = threading.Condition()
        self._subscriber = rospy.Subscriber(topic, msg_class, self._on_message, queue_size=None)

    def _on_message(self, message: Any) -> None:
        sender = str(message._connection_header.get("callerid", "")).lstrip("/")
        with self._condition:
            self.heard.append(Heard(message, sender, time.monotonic()))
            self._condition.notify_all()

    def mark(self) -> int:
        """An index for :meth:`wait_for`'s ``after``: only messages from now on count."""
        with self._condition:
            return len(self.heard)

    def since(self, index: int) -> list[Heard]:
        with self._condition:
            return self.heard[index:]

    def wait_for(
        self, predicate: Callable[[Heard], bool], *, after: int = 0, timeout: float = 10.0, what: str = ""
    ) -> Heard:
        deadline = time.monotonic() + timeout
        with self._condition:
            while True:
                for heard in self.heard[after:]:
                    if predicate(heard):
                        return heard
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    got = [(h.sender, h.message) for h in self.heard[after:]]
                    raise AssertionError(
                        f"{self.topic}: no {what or 'matching message'} within {timeout} s; got {got}"
                    )
                self._condition.wait(remaining)

    def wait_many(
        self,
        predicate: Callable[[Heard], bool],
        count: int,
        *,
        after: int = 0,
        timeout: float = 10.0,
        what: str = "",
    ) -> list[Heard]:
        """Wait until ``count`` messages after ``after`` satisfy ``predicate``; returns them."""
        matching: list[Heard] = []

        def enough(heard: Heard) -> bool:
            matching[:] = [h for h in self.heard[after:] if predicate(h)]
            return len(matching) >= count

        self.wait_for(enough, after=after, timeout=timeout, what=f"{count} x {what or 'matching message'}")
        return matching

    def wait_connected(self, publishers: int = 1, timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while self._subscriber.get_num_connections() < publishers:
            if time.monotonic() > deadline:
                raise AssertionError(
                    f"{self.topic}: {publishers} publisher(s) not connected within {timeout} s"
                )
            time.sleep(0.01)

    def close(self) -> None:
        self._subscriber.unregister()


class StateChanges(TopicRecorder):
    """/cyborg_controller/state_change."""

    def __init__(self) -> None:
        from cyborg_controller.msg import SystemState  # type: ignore[import-not-found]

        super().__init__("/cyborg_controller/state_change", SystemState)

    def wait_state(
        self, to_state: str, *, event: str | None = None, after: int = 0, timeout: float = 10.0
    ) -> Heard:
        return self.wait_for(
            lambda h: h.message.to_system_state == to_state and (event is None or h.message.event == event),
            after=after,
            timeout=timeout,
            what=f"change to {to_state!r}" + (f" on {event!r}" if event else ""),
        )

    def path(self, after: int = 0) -> list[tuple[str, str, str]]:
        return [
            (h.message.from_system_state, h.message.event, h.message.to_system_state)
            for h in self.since(after)
        ]


class EventSender:
    """Publishes events on /cyborg_controller/register_event, as a module does."""

    def __init__(self) -> None:
        import rospy
        from std_msgs.msg import String  # type: ignore[import-not-found]

        self._string = String
        self._publisher = rospy.Publisher("/cyborg_controller/register_event", String, queue_size=100)

    def wait_connected(self, subscriber: str = "/cyborg_controller", timeout: float = 10.0) -> None:
        """Wait until ``subscriber`` (the controller) is connected: another listener (a launched
        recorder) may connect first, and an event sent before the controller connects is lost."""
        deadline = time.monotonic() + timeout
        while not self._publisher.impl.has_connection(subscriber):
            if time.monotonic() > deadline:
                raise AssertionError(f"{subscriber} did not subscribe to register_event within {timeout} s")
            time.sleep(0.01)

    def send(self, event: str) -> float:
        """Publish ``event``; returns time.monotonic() of the send."""
        self._publisher.publish(self._string(data=event))
        return time.monotonic()

    def close(self) -> None:
        self._publisher.unregister()


@dataclass
class Observers:
    """Recorders and publishers of one test, closed at teardown."""

    opened: list[TopicRecorder | EventSender] = field(default_factory=list)

    def topic(self, topic: str, msg_class: Any) -> TopicRecorder:
        recorder = TopicRecorder(topic, msg_class)
        self.opened.append(recorder)
        return recorder

    def state_changes(self) -> StateChanges:
        recorder = StateChanges()
        self.opened.append(recorder)
        return recorder

    def events(self) -> EventSender:
        sender = EventSender()
        self.opened.append(sender)
        return sender

    def close(self) -> None:
        for item in self.opened:
            item.close()


def yaml_path(name: str) -> Path:
    """A machine/module configuration of tests/ros."""
    return ROS_TESTS / name
