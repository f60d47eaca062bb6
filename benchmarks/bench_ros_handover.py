"""Handover latency over ROS 1, beside the raw actionlib floor measured in the same run.

* ours: an event published on /cyborg_controller/register_event -> the next module's goal ACTIVE.
  The controller (``Controller`` on ``RosTransport``) runs in one process, two modules that accept
  goals and acknowledge cancels at once (``RosTransport`` action servers) in another, and this
  process publishes the events with plain rospy.
* floor: plain actionlib, no controller: an ``actionlib.ActionClient`` cancels the running goal,
  waits for PREEMPTED, sends the next goal to the other server and waits for ACTIVE; the two
  servers are plain ``actionlib.ActionServer`` s in a third process that accept and acknowledge
  cancels in their callbacks. Every subscriber asks for TCP_NODELAY, as our transport does.

Finished goals stay 0.02 s in the servers' status lists (``--status-list-timeout``; actionlib's
default 5 s makes back-to-back handovers carry hundreds of goals in every status message).
Both are stamped on the server side, right after the goal was accepted, with
``time.perf_counter()`` (CLOCK_MONOTONIC on Linux: one time line for every process of the
machine), and reported back on a topic. Ours and the floor run in alternating blocks, so load
changes of the shared machine hit both alike. The benchmark starts its own roscore on a free
port with a temporary ROS_HOME and stops everything it started.

Run: .venv/bin/python benchmarks/bench_ros_handover.py [--handovers 1000] [--block 100]
     [--status-list-timeout 0.02] [--resources]
"""

from __future__ import annotations

import argparse
import asyncio
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
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from _machine import machine_line, percentile
from _stamps import StampQueue, wait_until

MACHINE = """
states:
  idle: {action: bench/a, transitions: {to_b: b, aborted: idle}}
  b: {action: bench/b, RESOURCES transitions: {to_a: idle, aborted: idle}}
"""
OURS_REPORT = "/bench/ours_active"
FLOOR_REPORT = "/bench/floor_active"
FLOOR_ACTIONS = ("/bench_floor/a", "/bench_floor/b")
OUR_ACTIONS = ("/bench/a", "/bench/b")
# actionlib keeps finished goals in a server's status list for 5 s, and every status message carries
# the whole list. Back to back, about 250 handovers a second, the lists grow to hundreds of goals and
# serialising them dominates (ours and the floor alike); on the robot, with seconds between handovers,
# they hold a handful. The benchmark therefore keeps them short on all four servers by default.
ACTIONLIB_STATUS_LIST_TIMEOUT = 5.0
STATUS_LIST_TIMEOUT = 0.02
REGISTER_EVENT = "/cyborg_controller/register_event"
STATE_CHANGE = "/cyborg_controller/state_change"


def check_clock() -> None:
    """perf_counter must be CLOCK_MONOTONIC, which is system-wide, to compare stamps across processes."""
    implementation = time.get_clock_info("perf_counter").implementation
    if "CLOCK_MONOTONIC" not in implementation:
        raise SystemExit(
            f"time.perf_counter is {implementation}, not CLOCK_MONOTONIC: stamps would not compare"
        )


def force_tcp_nodelay() -> None:
    """Every rospy subscriber asks for TCP_NODELAY (creating a cyborg RosTransport does the same)."""
    import rospy  # type: ignore[import-not-found]

    original = rospy.topics.Subscriber.__init__
    if getattr(original, "_cyborg_nodelay", False):
        return

    def init(self: Any, *args: Any, tcp_nodelay: bool = True, **kwargs: Any) -> None:
        original(self, *args, tcp_nodelay=tcp_nodelay, **kwargs)

    init._cyborg_nodelay = True  # type: ignore[attr-defined]
    rospy.topics.Subscriber.__init__ = init


# --- the roles of the child processes ----------------------------------------------------------


def _run_until_signalled(clock: Any, transport: Any, start: Callable[[], object] | None = None) -> None:
    import rospy

    async def main() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        if start is not None:
            start()
        await stop.wait()

    try:
        clock.run(main())
    finally:
        transport.shutdown()
        rospy.signal_shutdown("benchmark done")
        clock.close()


def machine_yaml(resources: bool) -> str:
    """Both states without resources, or 'b' holding the speaker (every handover changes them)."""
    return MACHINE.replace("RESOURCES ", "resources: {speech: mod_b}, " if resources else "")


def role_controller() -> None:
    from cyborg.app.config import parse_config
    from cyborg.controller.runtime import Controller
    from cyborg.transport.clock import RealClock
    from cyborg.transport.ros import RosTransport

    clock = RealClock()
    transport = RosTransport(clock, process_name="cyborg_controller")
    machine = parse_config(machine_yaml(os.environ.get("BENCH_RESOURCES") == "1")).machine
    controller = Controller(transport.node("cyborg_controller"), machine)
    _run_until_signalled(clock, transport, controller.start)


def role_modules() -> None:
    from cyborg.transport.base import GoalStatus, ServerGoalHandle
    from cyborg.transport.clock import RealClock
    from cyborg.transport.messages import StateMachineAction, String
    from cyborg.transport.ros import RosTransport

    clock = RealClock()
    transport = RosTransport(clock, process_name="bench_modules")
    report = transport.node("bench_report").publisher(OURS_REPORT, String, queue_size=1000)

    def on_goal(handle: ServerGoalHandle[Any, Any, Any]) -> None:
        handle.accept()
        if handle.status is GoalStatus.ACTIVE:
            stamp = time.perf_counter()
            report.publish(String(f"{handle.goal.event} {stamp!r}"))

    for name, action in zip(("mod_a", "mod_b"), OUR_ACTIONS, strict=True):
        transport.node(name).action_server(action, StateMachineAction, on_goal, lambda h: h.canceled())
    _run_until_signalled(clock, transport)


def role_floor() -> None:
    force_tcp_nodelay()
    import actionlib  # type: ignore[import-not-found]
    import rospy
    from cyborg_controller.msg import StateMachineAction  # type: ignore[import-not-found]
    from std_msgs.msg import String  # type: ignore[import-not-found]

    rospy.init_node("bench_floor", disable_signals=True)
    report = rospy.Publisher(FLOOR_REPORT, String, queue_size=1000)

    def on_goal(handle: Any) -> None:  # rospy thread
        handle.set_accepted()
        stamp = time.perf_counter()
        report.publish(String(f"{handle.get_goal().event} {stamp!r}"))

    servers = []
    for action in FLOOR_ACTIONS:
        server = actionlib.ActionServer(
            action, StateMachineAction, on_goal, lambda h: h.set_canceled(), auto_start=False
        )
        server.start()
        servers.append(server)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    stop.wait()
    rospy.signal_shutdown("benchmark done")


# --- the measuring process ---------------------------------------------------------------------


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def stop_process(process: subprocess.Popen[bytes] | None, grace: float = 10.0) -> None:
    """Stop a child we started (it leads its own process group) and whatever it started."""
    if process is None or process.poll() is not None:
        return
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGINT)
    try:
        process.wait(grace)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(5)


@contextlib.contextmanager
def ros_graph() -> Iterator[dict[str, str]]:
    """A roscore on a free port with a temporary ROS_HOME; yields the environment of its nodes."""
    port = free_port()
    ros_home = Path(tempfile.mkdtemp(prefix="cyborg-bench-ros-"))
    env = {
        **os.environ,
        "ROS_MASTER_URI": f"http://localhost:{port}",
        "ROS_HOSTNAME": "localhost",
        "ROS_HOME": str(ros_home),
    }
    env.pop("ROS_IP", None)
    core = None
    try:
        core = subprocess.Popen(
            ["roscore", "-p", str(port)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        import xmlrpc.client

        master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
        deadline = time.monotonic() + 30
        while True:
            try:
                answer: Any = master.lookupNode("/bench", "/rosout")
                if answer[0] == 1:
                    break
            except (OSError, xmlrpc.client.Fault):
                pass  # not up yet (or another program answers on the port: roscore then exits)
            if core.poll() is not None or time.monotonic() > deadline:
                raise SystemExit("roscore did not start; fix: scripts/install-ros")
            time.sleep(0.05)
        yield env
    finally:
        stop_process(core)
        shutil.rmtree(ros_home, ignore_errors=True)


def spawn(role: str, env: dict[str, str]) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, __file__, "--role", role], env=env, start_new_session=True)


class Reports(StampQueue):
    """Stamps reported by the servers, as (event, stamp) in arrival order."""

    def __init__(self, topic: str) -> None:
        import rospy
        from std_msgs.msg import String

        super().__init__()
        self.sub = rospy.Subscriber(topic, String, self._on, queue_size=1000)


class Ours:
    """Events through the controller; latency to the next module's goal ACTIVE."""

    def __init__(self) -> None:
        import rospy
        from std_msgs.msg import String

        self.reports = Reports(OURS_REPORT)
        self.String = String
        self.pub = rospy.Publisher(REGISTER_EVENT, String, queue_size=100)
        self.count = 0

    def ready(self) -> None:
        wait_until(lambda: self.pub.get_num_connections() >= 1, 30, "the controller to subscribe to events")
        wait_until(lambda: self.reports.sub.get_num_connections() >= 1, 30, "the modules' reports")
        # The controller is in 'idle' once its first goal is ACTIVE; a handover back and forth proves it.
        self.warm(4)

    def one(self) -> float:
        event = "to_b" if self.count % 2 == 0 else "to_a"
        self.count += 1
        sent = time.perf_counter()
        self.pub.publish(self.String(event))
        return (self.reports.next(event) - sent) * 1000

    def warm(self, n: int) -> None:
        self.reports.drain()
        for _ in range(n):
            self.one()


class Floor:
    """Plain actionlib: cancel, wait PREEMPTED, next goal to the other server, wait ACTIVE."""

    def __init__(self) -> None:
        import actionlib
        import rospy
        from cyborg_controller.msg import StateMachineAction, StateMachineGoal

        self.actionlib = actionlib
        self.Goal = StateMachineGoal
        self.reports = Reports(FLOOR_REPORT)
        self.clients = [actionlib.ActionClient(name, StateMachineAction) for name in FLOOR_ACTIONS]
        for client in self.clients:
            if not client.wait_for_server(rospy.Duration(30)):
                raise SystemExit("the floor's action servers did not come up")
        self.count = 0
        self.client_side: list[float] = []
        self.handle, self.done = self._send()

    def _send(self) -> tuple[Any, threading.Event]:
        actionlib = self.actionlib
        active, done = threading.Event(), threading.Event()

        def transition(handle: Any) -> None:
            state = handle.get_comm_state()
            if state == actionlib.CommState.ACTIVE:
                active.set()
            elif state == actionlib.CommState.DONE:
                active.set()
                done.set()

        event = f"e{self.count}"
        client = self.clients[self.count % 2]
        self.count += 1
        handle = client.send_goal(self.Goal("x", event, "y"), transition_cb=transition)
        if not active.wait(10):
            raise SystemExit(f"floor goal {event} never became ACTIVE")
        return handle, done

    def ready(self) -> None:
        wait_until(lambda: self.reports.sub.get_num_connections() >= 1, 30, "the floor's reports")
        self.warm(4)

    def one(self) -> float:
        from actionlib_msgs.msg import GoalStatus  # type: ignore[import-not-found]

        event = f"e{self.count}"
        start = time.perf_counter()
        self.handle.cancel()
        if not self.done.wait(10) or self.handle.get_goal_status() != GoalStatus.PREEMPTED:
            raise SystemExit(f"floor: cancel ended {self.handle.get_goal_status()}, not PREEMPTED")
        self.handle, self.done = self._send()
        self.client_side.append((time.perf_counter() - start) * 1000)
        return (self.reports.next(event) - start) * 1000

    def warm(self, n: int) -> None:
        self.reports.drain()
        for _ in range(n):
            self.one()
        self.client_side.clear()


def bench(handovers: int, block: int, status_list_timeout: float, resources: bool) -> dict[str, Any]:
    check_clock()
    with ros_graph() as env:
        env["BENCH_RESOURCES"] = "1" if resources else "0"
        os.environ.update(env)  # rospy in this process reads them at init time
        import xmlrpc.client

        master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
        for action in (*OUR_ACTIONS, *FLOOR_ACTIONS):  # actionlib reads it when a server starts
            master.setParam("/bench", f"{action}/status_list_timeout", status_list_timeout)
        children: list[subprocess.Popen[bytes]] = []
        try:
            children.append(spawn("modules", env))
            children.append(spawn("floor", env))
            time.sleep(0.5)  # the modules' servers first, so the controller's first goal finds them
            children.append(spawn("controller", env))
            force_tcp_nodelay()
            import rospy

            rospy.init_node("bench_sender", disable_signals=True)
            ours, floor = Ours(), Floor()
            ours.ready()
            floor.ready()
            ours_ms: list[float] = []
            floor_ms: list[float] = []
            started = time.perf_counter()
            while len(ours_ms) < handovers:
                n = min(block, handovers - len(ours_ms))
                ours_ms += [ours.one() for _ in range(n)]
                floor_ms += [floor.one() for _ in range(n)]
            elapsed = time.perf_counter() - started
            for child in children:
                if child.poll() is not None:
                    raise SystemExit(f"a benchmark process ended early (exit {child.returncode})")
            rospy.signal_shutdown("benchmark done")
            return {
                "ours": ours_ms,
                "floor": floor_ms,
                "floor_client": floor.client_side,
                "elapsed": elapsed,
            }
        finally:
            for child in reversed(children):
                stop_process(child)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--handovers", type=int, default=1000, help="handovers of each kind (>= 500)")
    parser.add_argument("--block", type=int, default=100, help="handovers per alternating block")
    parser.add_argument(
        "--status-list-timeout",
        type=float,
        default=STATUS_LIST_TIMEOUT,
        help=f"seconds finished goals stay in every server's status list (default %(default)s; "
        f"actionlib's own default: {ACTIONLIB_STATUS_LIST_TIMEOUT})",
    )
    parser.add_argument(
        "--resources",
        action="store_true",
        help="state 'b' holds a resource: /state_resources changes every time",
    )
    parser.add_argument("--role", choices=["controller", "modules", "floor"], help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role is not None:
        {"controller": role_controller, "modules": role_modules, "floor": role_floor}[args.role]()
        return
    if shutil.which("roscore") is None:
        raise SystemExit("no roscore; fix: scripts/install-ros")
    result = bench(args.handovers, args.block, args.status_list_timeout, args.resources)
    ours, floor, client = result["ours"], result["floor"], result["floor_client"]

    def row(label: str, values: list[float], target: str = "") -> str:
        return f"| {label} | {percentile(values, 50):.2f} | {percentile(values, 99):.2f} | {max(values):.2f} | {len(values)} | {target} |"

    print(f"machine: {machine_line()}")
    print(
        f"status_list_timeout {args.status_list_timeout:g} s on all four servers; /state_resources "
        + ("changes on every handover" if args.resources else "stays the same")
    )
    print(f"wall time of the measured blocks: {result['elapsed']:.1f} s")
    print("| handover | p50 ms | p99 ms | max ms | count | target |")
    print("|---|---:|---:|---:|---:|---|")
    print(row("ours: event -> next module's goal ACTIVE (server side)", ours, "p50 <= 5, p99 <= 20"))
    print(row("floor: cancel -> PREEMPTED -> next goal ACTIVE (server side)", floor))
    print(row("floor, ACTIVE seen by the client", client))
    print(
        f"ratio ours/floor: p50 {percentile(ours, 50) / percentile(floor, 50):.2f}, "
        f"p99 {percentile(ours, 99) / percentile(floor, 99):.2f}"
    )


if __name__ == "__main__":
    main()
