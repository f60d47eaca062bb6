"""Handover latency over ROS 1, beside the raw actionlib floor measured in the same run.

* ours: an event published on /cyborg_controller/register_event -> the next module's goal ACTIVE.
  The controller (``Controller`` on ``RosTransport``) runs in one process, two modules that accept
  goals and acknowledge cancels at once (``RosTransport`` action servers) in another, and this
  process publishes the events with plain rospy.
* floor: the same hops with plain rospy and actionlib, no controller: an event published on a
  topic -> a plain rospy node (its own process) cancels the running goal, and when the goal is
  DONE (PREEMPTED) sends the next goal to the other server -> ACTIVE. Its two servers are plain
  ``actionlib.ActionServer`` s in a third process that accept goals and acknowledge cancels in
  their callbacks. The floor node chains the steps in actionlib's callbacks: no thread waits.
* floor without the event hop (the floor of the benchmarks before 2026-11-26, kept for
  comparison): an ``actionlib.ActionClient`` in this process cancels the running goal, waits
  for PREEMPTED and sends the next goal; timed from ``cancel()``, so one topic hop short of ours.

Every subscriber asks for TCP_NODELAY, as our transport does. Finished goals stay 0.02 s in the
servers' status lists (``--status-list-timeout``; actionlib's default 5 s makes back-to-back
handovers carry hundreds of goals in every status message). All are stamped on the server side,
right after the goal was accepted, with ``time.perf_counter()`` (CLOCK_MONOTONIC on Linux: one
time line for every process of the machine), and reported back on a topic. The contenders run
in alternating blocks (the order reversed every other round), back to back and then paced (a
random 0.1-0.3 s pause before each handover, as on a robot), so load changes of the shared
machine hit them alike. ``--trace`` stamps every step of ours and the floor in their processes
and prints where the time goes. The benchmark starts its own roscore on a free port with a
temporary ROS_HOME and stops everything it started.

Run: .venv/bin/python benchmarks/bench_ros_handover.py [--handovers 1000] [--block 100]
     [--paced 200] [--trace] [--status-list-timeout 0.02] [--resources]
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

import _trace
from _handover import PACED_BLOCK, PACED_PAUSE, cpu_seconds, load, measure, report
from _machine import machine_line
from _stamps import StampQueue, wait_until

MACHINE = """
states:
  idle: {action: bench/a, transitions: {to_b: b, aborted: idle}}
  b: {action: bench/b, RESOURCES transitions: {to_a: idle, aborted: idle}}
"""
OURS_REPORT = "/bench/ours_active"
FLOOR_REPORT = "/bench/floor_active"
FLOOR_EVENT = "/bench_floor/event"
FLOOR_ACTIONS = ("/bench_floor/a", "/bench_floor/b")
DIRECT_REPORT = "/bench/direct_active"
DIRECT_ACTIONS = ("/bench_direct/a", "/bench_direct/b")
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


def _run_until_signalled(
    role: str, clock: Any, transport: Any, start: Callable[[], object] | None = None
) -> None:
    import rospy

    async def main() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        if start is not None:
            start()
        await stop.wait()

    profile_to = os.environ.get("BENCH_CPROFILE")  # a directory: profile the loop's thread there
    profiler = None
    if profile_to:
        import cProfile

        profiler = cProfile.Profile()
        profiler.enable()
    try:
        clock.run(main())
    finally:
        if profiler is not None:
            profiler.disable()
            profiler.dump_stats(str(Path(profile_to, f"{role}.prof")))
        transport.shutdown()
        rospy.signal_shutdown("benchmark done")
        clock.close()
        _trace.dump(role)


def machine_yaml(resources: bool) -> str:
    """Both states without resources, or 'b' holding the speaker (every handover changes them)."""
    return MACHINE.replace("RESOURCES ", "resources: {speech: mod_b}, " if resources else "")


def keep_writer_threads() -> None:
    """``--writer-threads``: undo the transport's write-at-once (rospy's writer thread per
    connection, as before 2026-11-26); ``--thread-reads``: undo its reads on the loop (rospy's
    reading thread per connection hands each message to the loop, as before 2026-11-26 13:00 UTC);
    to compare. Called right after the transport is made."""
    if os.environ.get("BENCH_WRITER_THREADS") == "1":
        import rospy.impl.tcpros_pubsub
        import rospy.topics

        rospy.topics.QueuedConnection = rospy.impl.tcpros_pubsub.QueuedConnection
    if os.environ.get("BENCH_THREAD_READS") == "1":
        from rospy.impl.tcpros_base import TCPROSTransport

        from cyborg.transport.ros import reads

        TCPROSTransport.receive_loop = reads._original_receive_loop


def role_controller() -> None:
    from cyborg.app.config import parse_config
    from cyborg.controller.runtime import Controller
    from cyborg.transport.clock import RealClock
    from cyborg.transport.ros import RosTransport

    clock = RealClock()
    transport = RosTransport(clock, process_name="cyborg_controller")
    keep_writer_threads()
    machine = parse_config(machine_yaml(os.environ.get("BENCH_RESOURCES") == "1")).machine
    if _trace.enabled():
        trace_controller()
    controller = Controller(transport.node("cyborg_controller"), machine)
    _run_until_signalled("controller", clock, transport, controller.start)


def trace_controller() -> None:
    """Note the steps of our handover in the controller's process (``--trace``)."""
    from cyborg.controller.runtime import Controller
    from cyborg.transport._goals import ClientGoal
    from cyborg.transport.base import Transport
    from cyborg.transport.ros.actions import RosActionClient, _RosClientGoalHandle
    from cyborg.transport.ros.topics import RosSubscription

    wrap = _trace.wrap
    wrap(
        RosSubscription,
        "_on_ros",
        "c1 event read",
        when=lambda sub, *_: sub.topic == REGISTER_EVENT,
    )
    wrap(Controller, "_on_event_message", "c2 event to the controller")
    wrap(_RosClientGoalHandle, "_request_cancel", "c3 cancel: publish", "c4 cancel: published")
    wrap(
        Transport,
        "arrive",
        "c5 result read",
        when=lambda _t, channel, *_a, **_k: channel.endswith("#result"),
    )
    wrap(
        ClientGoal,
        "update_status",
        "c6 result to the controller",
        when=lambda _h, status, *_: status.is_terminal,
    )
    wrap(Controller, "_announce", "c7 next state entered (resources set)", "c8 state change published")
    wrap(RosActionClient, "send_goal", "c9 goal: send", "c10 goal: published")


def role_modules() -> None:
    from cyborg.transport.base import GoalStatus, ServerGoalHandle
    from cyborg.transport.clock import RealClock
    from cyborg.transport.messages import StateMachineAction, String
    from cyborg.transport.ros import RosTransport

    clock = RealClock()
    transport = RosTransport(clock, process_name="bench_modules")
    keep_writer_threads()
    report = transport.node("bench_report").publisher(OURS_REPORT, String, queue_size=1000)

    def on_goal(handle: ServerGoalHandle[Any, Any, Any]) -> None:
        handle.accept()
        if handle.status is GoalStatus.ACTIVE:
            stamp = time.perf_counter()
            report.publish(String(f"{handle.goal.event} {stamp!r}"))

    def on_cancel(handle: ServerGoalHandle[Any, Any, Any]) -> None:
        handle.canceled()

    if _trace.enabled():
        from cyborg.transport.ros.actions import RosActionServer

        _trace.wrap(RosActionServer, "_cancel_cb", "m1 cancel read")
        _trace.wrap(RosActionServer, "_goal_cb", "m3 goal read")
        on_cancel_traced, on_goal_traced = on_cancel, on_goal

        def on_cancel(handle: ServerGoalHandle[Any, Any, Any]) -> None:
            _trace.mark("m2 cancel to the module")
            on_cancel_traced(handle)

        def on_goal(handle: ServerGoalHandle[Any, Any, Any]) -> None:
            _trace.mark("m4 goal to the module")
            on_goal_traced(handle)

    for name, action in zip(("mod_a", "mod_b"), OUR_ACTIONS, strict=True):
        transport.node(name).action_server(action, StateMachineAction, on_goal, on_cancel)
    _run_until_signalled("modules", clock, transport)


def _wait_for_signal() -> None:
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    stop.wait()


def role_floor() -> None:
    """The plain actionlib servers of the floor and of the floor without the event hop."""
    force_tcp_nodelay()
    import actionlib  # type: ignore[import-not-found]
    import rospy
    from cyborg_controller.msg import StateMachineAction  # type: ignore[import-not-found]
    from std_msgs.msg import String  # type: ignore[import-not-found]

    rospy.init_node("bench_floor", disable_signals=True)
    servers = []
    for actions, topic in ((FLOOR_ACTIONS, FLOOR_REPORT), (DIRECT_ACTIONS, DIRECT_REPORT)):
        report = rospy.Publisher(topic, String, queue_size=1000)

        def on_goal(handle: Any, report: Any = report) -> None:  # rospy thread
            _trace.mark("s3 goal received (rospy thread)")
            handle.set_accepted()
            stamp = time.perf_counter()
            report.publish(String(f"{handle.get_goal().event} {stamp!r}"))

        def on_cancel(handle: Any) -> None:  # rospy thread
            _trace.mark("s1 cancel received (rospy thread)")
            handle.set_canceled()
            _trace.mark("s2 cancel acknowledged")

        for action in actions:
            server = actionlib.ActionServer(action, StateMachineAction, on_goal, on_cancel, auto_start=False)
            server.start()
            servers.append(server)
    _wait_for_signal()
    rospy.signal_shutdown("benchmark done")
    _trace.dump("floor")


def role_floor_controller() -> None:
    """The floor's plain rospy node: on an event, cancel the goal; once it is DONE, send the next.

    Each step runs in the actionlib callback that makes it possible, on rospy's threads: the
    least a node can do between the event and the next goal.
    """
    force_tcp_nodelay()
    import actionlib
    import rospy
    from cyborg_controller.msg import StateMachineAction, StateMachineGoal
    from std_msgs.msg import String

    rospy.init_node("bench_floor_controller", disable_signals=True)
    clients = [actionlib.ActionClient(name, StateMachineAction) for name in FLOOR_ACTIONS]
    for client in clients:
        if not client.wait_for_server(rospy.Duration(30)):
            raise SystemExit("the floor's action servers did not come up")
    lock = threading.RLock()  # cancel() calls the transition callback at once, on this thread
    state: dict[str, Any] = {"handle": None, "cancelled": None, "next": "", "count": 0}

    def send(event: str) -> None:
        client = clients[state["count"] % 2]
        state["count"] += 1
        state["handle"] = client.send_goal(StateMachineGoal("x", event, "y"), transition_cb=transition)
        _trace.mark("f4 goal published")

    def transition(handle: Any) -> None:  # rospy thread
        if handle.get_comm_state() != actionlib.CommState.DONE:
            return
        with lock:
            if state["cancelled"] is None or handle != state["cancelled"]:
                return
            _trace.mark("f3 cancelled goal DONE (rospy thread)")
            state["cancelled"] = None
            send(state["next"])

    def on_event(message: Any) -> None:  # rospy thread
        _trace.mark("f1 event received (rospy thread)")
        with lock:
            state["cancelled"], state["next"] = state["handle"], str(message.data)
            state["handle"].cancel()
        _trace.mark("f2 cancel published")

    with lock:
        send("first")
    rospy.Subscriber(FLOOR_EVENT, String, on_event, queue_size=None)
    _wait_for_signal()
    rospy.signal_shutdown("benchmark done")
    _trace.dump("floor_controller")


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


SRC = str(Path(__file__).resolve().parents[1] / "src")


def spawn(role: str, env: dict[str, str]) -> subprocess.Popen[bytes]:
    # This checkout's code: without it the processes run whatever copy the venv has installed
    # (from another worktree, the main one's).
    path = os.pathsep.join(p for p in (SRC, env.get("PYTHONPATH", "")) if p)
    return subprocess.Popen(
        [sys.executable, __file__, "--role", role], env={**env, "PYTHONPATH": path}, start_new_session=True
    )


class Reports(StampQueue):
    """Stamps reported by the servers, as (event, stamp) in arrival order."""

    def __init__(self, topic: str) -> None:
        import rospy
        from std_msgs.msg import String

        super().__init__()
        self.sub = rospy.Subscriber(topic, String, self._on, queue_size=1000)


class Ours:
    """Events through the controller; latency to the next module's goal ACTIVE."""

    name = "ours"
    waiting_for = "the controller to subscribe to events"

    def __init__(self, events: str = REGISTER_EVENT, reports: str = OURS_REPORT) -> None:
        import rospy
        from std_msgs.msg import String

        self.reports = Reports(reports)
        self.String = String
        self.pub = rospy.Publisher(events, String, queue_size=100)
        self.count = 0
        self.windows: list[tuple[float, float]] = []  # (event published, goal ACTIVE), for --trace

    def ready(self) -> None:
        wait_until(lambda: self.pub.get_num_connections() >= 1, 30, self.waiting_for)
        wait_until(lambda: self.reports.sub.get_num_connections() >= 1, 30, f"the {self.name} reports")
        # The first goal is ACTIVE once a handover back and forth went through.
        self.warm(4)

    def event(self) -> str:
        return "to_b" if self.count % 2 == 0 else "to_a"

    def one(self) -> float:
        event = self.event()
        self.count += 1
        sent = time.perf_counter()
        self.pub.publish(self.String(event))
        active = self.reports.next(event)
        self.windows.append((sent, active))
        return (active - sent) * 1000

    def warm(self, n: int) -> None:
        self.reports.drain()
        for _ in range(n):
            self.one()
        self.windows.clear()


class Floor(Ours):
    """The same hops in plain rospy and actionlib: event -> cancel -> PREEMPTED -> next goal ACTIVE."""

    name = "floor"
    waiting_for = "the floor node to subscribe to events"

    def __init__(self) -> None:
        super().__init__(FLOOR_EVENT, FLOOR_REPORT)

    def event(self) -> str:
        return f"e{self.count}"


class Direct:
    """Plain actionlib in this process, timed from cancel(): cancel, wait PREEMPTED, next goal to
    the other server, wait ACTIVE (one topic hop short of ours)."""

    name = "direct"

    def __init__(self) -> None:
        import actionlib
        import rospy
        from cyborg_controller.msg import StateMachineAction, StateMachineGoal

        self.actionlib = actionlib
        self.Goal = StateMachineGoal
        self.reports = Reports(DIRECT_REPORT)
        self.clients = [actionlib.ActionClient(name, StateMachineAction) for name in DIRECT_ACTIONS]
        for client in self.clients:
            if not client.wait_for_server(rospy.Duration(30)):
                raise SystemExit("the floor's action servers did not come up")
        self.count = 0
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

        event = f"d{self.count}"
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

        event = f"d{self.count}"
        start = time.perf_counter()
        self.handle.cancel()
        # LOST: under load the server's status list (0.02 s) can drop the goal before its result
        # arrives, and actionlib gives up on it; the cancel went through all the same.
        if not self.done.wait(10) or self.handle.get_goal_status() not in (
            GoalStatus.PREEMPTED,
            GoalStatus.LOST,
        ):
            raise SystemExit(f"floor: cancel ended {self.handle.get_goal_status()}, not PREEMPTED")
        self.handle, self.done = self._send()
        return (self.reports.next(event) - start) * 1000

    def warm(self, n: int) -> None:
        self.reports.drain()
        for _ in range(n):
            self.one()


OURS_STEPS = (
    "c1 event read",
    "c2 event to the controller",
    "c3 cancel: publish",
    "c4 cancel: published",
    "m1 cancel read",
    "m2 cancel to the module",
    "c5 result read",
    "c6 result to the controller",
    "c7 next state entered (resources set)",
    "c8 state change published",
    "c9 goal: send",
    "c10 goal: published",
    "m3 goal read",
    "m4 goal to the module",
)
FLOOR_STEPS = (
    "f1 event received (rospy thread)",
    "f2 cancel published",
    "s1 cancel received (rospy thread)",
    "s2 cancel acknowledged",
    "f3 cancelled goal DONE (rospy thread)",
    "f4 goal published",
    "s3 goal received (rospy thread)",
)


ROLES = ("modules", "floor", "controller", "floor_controller")  # in the order they are started


def bench(args: argparse.Namespace) -> dict[str, Any]:
    check_clock()
    trace_dir = tempfile.mkdtemp(prefix="cyborg-bench-trace-") if args.trace else ""
    with ros_graph() as env:
        env["BENCH_RESOURCES"] = "1" if args.resources else "0"
        env["BENCH_TRACE"] = trace_dir
        env["BENCH_WRITER_THREADS"] = "1" if args.writer_threads else "0"
        env["BENCH_THREAD_READS"] = "1" if args.thread_reads else "0"
        os.environ.update(env)  # rospy in this process reads them at init time
        import xmlrpc.client

        master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
        for action in (*OUR_ACTIONS, *FLOOR_ACTIONS, *DIRECT_ACTIONS):  # read when a server starts
            master.setParam("/bench", f"{action}/status_list_timeout", args.status_list_timeout)
        children: list[subprocess.Popen[bytes]] = []
        result: dict[str, Any] = {"load": [load()]}
        try:
            children.append(spawn("modules", env))
            children.append(spawn("floor", env))
            time.sleep(0.5)  # the servers first, so the controllers' first goals find them
            children.append(spawn("controller", env))
            children.append(spawn("floor_controller", env))
            force_tcp_nodelay()
            import rospy

            rospy.init_node("bench_sender", disable_signals=True)
            ours, floor = Ours(), Floor()
            contenders: list[Any] = [ours, floor] if args.no_direct else [ours, floor, Direct()]
            for contender in contenders:
                contender.ready()
            started = time.perf_counter()
            cpu_before = {role: cpu_seconds(child.pid) for role, child in zip(ROLES, children, strict=True)}
            result["b2b"] = measure(contenders, args.handovers, args.block, False, args.seed)
            result["b2b_elapsed"] = time.perf_counter() - started
            served = {"floor": args.handovers * (2 if len(contenders) == 3 else 1)}
            result["cpu"] = {
                role: (cpu_seconds(child.pid) - cpu_before[role]) * 1000 / served.get(role, args.handovers)
                for role, child in zip(ROLES, children, strict=True)
            }
            result["load"].append(load())
            windows = {("b2b", c.name): list(c.windows) for c in (ours, floor)}
            if args.paced:
                ours.windows.clear()
                floor.windows.clear()
                result["paced"] = measure(contenders, args.paced, PACED_BLOCK, True, args.seed + 1)
                result["load"].append(load())
                windows.update({("paced", c.name): list(c.windows) for c in (ours, floor)})
            for child in children:
                if child.poll() is not None:
                    raise SystemExit(f"a benchmark process ended early (exit {child.returncode})")
            rospy.signal_shutdown("benchmark done")
        finally:
            for child in reversed(children):
                stop_process(child)
    if trace_dir:
        steps = _trace.load(trace_dir)
        result["trace"] = {
            f"{name}, {'back to back' if mode == 'b2b' else 'paced'}": _trace.breakdown(
                found, steps, OURS_STEPS if name == "ours" else FLOOR_STEPS
            )
            for (mode, name), found in windows.items()
        }
        shutil.rmtree(trace_dir, ignore_errors=True)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--handovers", type=int, default=1000, help="back-to-back handovers of each kind")
    parser.add_argument("--block", type=int, default=100, help="back-to-back handovers per alternating block")
    parser.add_argument(
        "--paced",
        type=int,
        default=200,
        help=f"paced handovers of each kind ({PACED_PAUSE[0]:g}-{PACED_PAUSE[1]:g} s pause before each, "
        f"blocks of {PACED_BLOCK}; 0: none)",
    )
    parser.add_argument("--seed", type=int, default=1, help="seed of the paced pauses")
    parser.add_argument(
        "--no-direct", action="store_true", help="leave out the floor without the event hop (quicker)"
    )
    parser.add_argument("--trace", action="store_true", help="print where the time of a handover goes")
    parser.add_argument(
        "--writer-threads",
        action="store_true",
        help="our processes keep rospy's writer thread per connection (no write at once), to compare",
    )
    parser.add_argument(
        "--thread-reads",
        action="store_true",
        help="our processes read every subscriber connection on rospy's thread, not on the loop, to compare",
    )
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
    parser.add_argument(
        "--role", choices=["controller", "modules", "floor", "floor_controller"], help=argparse.SUPPRESS
    )
    args = parser.parse_args()
    if args.role is not None:
        {
            "controller": role_controller,
            "modules": role_modules,
            "floor": role_floor,
            "floor_controller": role_floor_controller,
        }[args.role]()
        return
    if shutil.which("roscore") is None:
        raise SystemExit("no roscore; fix: scripts/install-ros")
    result = bench(args)

    print(f"machine: {machine_line()}")
    print(
        "load average (1 min) at the start / after back to back / after paced: "
        + " / ".join(f"{value:.1f}" for value in result["load"])
    )
    print(
        f"status_list_timeout {args.status_list_timeout:g} s on all six servers; /state_resources "
        + ("changes on every handover" if args.resources else "stays the same")
        + ("; our processes keep rospy's writer threads" if args.writer_threads else "")
        + ("; our processes read on rospy's threads" if args.thread_reads else "")
    )
    print(f"wall time of the back-to-back blocks: {result['b2b_elapsed']:.1f} s")
    cpu = result["cpu"]
    print(
        "CPU per back-to-back handover (user + system time over all the blocks, idle included): "
        f"controller {cpu['controller']:.3f} ms, floor node {cpu['floor_controller']:.3f} ms; "
        f"modules {cpu['modules']:.3f} ms, floor servers {cpu['floor']:.3f} ms"
    )
    report(
        result,
        "p50 <= 1.2x floor",
        "event -> cancel -> PREEMPTED -> next goal ACTIVE",
        "cancel -> PREEMPTED -> next goal ACTIVE",
    )
    if "trace" in result:
        for name, rows in result["trace"].items():
            print(f"\nwhere the time goes, {name} (medians over the handovers):")
            print("| step | ms since the event was published | ms since the previous step | seen |")
            print("|---|---:|---:|---:|")
            for step, since_start, since_previous, seen in rows:
                print(f"| {step} | {since_start:.3f} | {since_previous:.3f} | {seen} |")


if __name__ == "__main__":
    main()
