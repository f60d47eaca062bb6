"""Handover latency over ROS 2, beside the raw rclpy action floor measured in the same run.

* ours: an event published on /cyborg_controller/register_event -> the next module's goal
  accepted. The controller (``Controller`` on ``Ros2Transport``) runs in one process, two
  modules that accept goals and acknowledge cancels at once (``Ros2Transport`` action servers)
  in another, and this process publishes the events with plain rclpy.
* floor: the same hops with plain rclpy, no controller: an event published on a topic -> a
  plain rclpy node (its own process, ``rclpy.spin``) cancels the running goal and, when its
  result (CANCELED) comes, sends the next goal to the other server -> accepted. Each step runs
  in the rclpy callback that makes it possible. The two servers are plain ``ActionServer`` s in
  a third process that accept goals and end a goal CANCELED as soon as its cancel is accepted
  (the execute callback waits for it on an event, then for rcl to mark the goal canceling).
* floor without the event hop (the floor of the benchmarks before 2026-11-26, kept for
  comparison): an ``ActionClient`` in this process cancels the running goal, waits for
  CANCELED, sends the next goal and waits for it to be accepted; timed from the cancel, so one
  topic hop short of ours.

All are stamped on the server side, right after the goal was accepted, with
``time.perf_counter()`` (CLOCK_MONOTONIC: one time line for every process of the machine),
and reported back on a topic. The contenders run in alternating blocks (the order reversed
every other round), back to back and then paced (a random 0.1-0.3 s pause before each
handover, as on a robot), so load changes of the shared machine hit them alike. Every process
runs on one random ROS_DOMAIN_ID with discovery kept on this host.

Run: .venv-ros2/bin/python benchmarks/bench_ros2_handover.py [--handovers 1000] [--block 100]
     [--paced 200] [--no-direct]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from _handover import PACED_BLOCK, PACED_PAUSE, cpu_seconds, load, measure, report
from _machine import machine_line
from _stamps import StampQueue, wait_until

MACHINE = """
states:
  idle: {action: bench/a, transitions: {to_b: b, aborted: idle}}
  b: {action: bench/b, transitions: {to_a: idle, aborted: idle}}
"""
OURS_REPORT = "/bench/ours_active"
FLOOR_REPORT = "/bench/floor_active"
FLOOR_ACTIONS = ("/bench_floor/a", "/bench_floor/b")
FLOOR_EVENT = "/bench_floor/event"
DIRECT_REPORT = "/bench/direct_active"
DIRECT_ACTIONS = ("/bench_direct/a", "/bench_direct/b")
OUR_ACTIONS = ("/bench/a", "/bench/b")
REGISTER_EVENT = "/cyborg_controller/register_event"


def _run_until_signalled(role: str, clock: Any, transport: Any, start: Any = None) -> None:
    async def main() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        if start is not None:
            start()
        print("ready", flush=True)
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
            profiler.dump_stats(os.path.join(profile_to, f"{role}.prof"))
        transport.close()
        clock.close()


def role_controller() -> None:
    from cyborg.app.config import parse_config
    from cyborg.controller.runtime import Controller
    from cyborg.transport.clock import RealClock
    from cyborg.transport.ros2 import Ros2Transport

    clock = RealClock()
    transport = Ros2Transport(clock)
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)
    _run_until_signalled("controller", clock, transport, controller.start)


def role_modules() -> None:
    from cyborg.transport.base import GoalStatus, ServerGoalHandle
    from cyborg.transport.clock import RealClock
    from cyborg.transport.messages import StateMachineAction, String
    from cyborg.transport.ros2 import Ros2Transport

    clock = RealClock()
    transport = Ros2Transport(clock)
    report = transport.node("bench_report").publisher(OURS_REPORT, String, queue_size=1000)

    def on_goal(handle: ServerGoalHandle[Any, Any, Any]) -> None:
        handle.accept()
        if handle.status is GoalStatus.ACTIVE:
            report.publish(String(f"{handle.goal.event} {time.perf_counter()!r}"))

    for name, action in zip(("mod_a", "mod_b"), OUR_ACTIONS, strict=True):
        transport.node(name).action_server(action, StateMachineAction, on_goal, lambda h: h.canceled())
    _run_until_signalled("modules", clock, transport)


def role_floor() -> None:
    import rclpy
    from cyborg_controller.action import StateMachine
    from rclpy.action import ActionServer, CancelResponse, GoalResponse
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.node import Node
    from std_msgs.msg import String

    rclpy.init()
    node = Node("bench_floor")
    reports = {
        action: node.create_publisher(String, topic, 1000)
        for actions, topic in ((FLOOR_ACTIONS, FLOOR_REPORT), (DIRECT_ACTIONS, DIRECT_REPORT))
        for action in actions
    }
    cancels: dict[bytes, threading.Event] = {}

    def accepted(handle: Any, report: Any) -> None:
        cancels[bytes(handle.goal_id.uuid)] = threading.Event()
        report.publish(String(data=f"{handle.request.event} {time.perf_counter()!r}"))
        handle.execute()

    def execute(handle: Any) -> Any:
        cancels[bytes(handle.goal_id.uuid)].wait()
        while not handle.is_cancel_requested:
            time.sleep(0.0001)  # rcl marks it canceling just after the cancel callback
        handle.canceled()
        del cancels[bytes(handle.goal_id.uuid)]
        return StateMachine.Result()

    def cancel(handle: Any) -> CancelResponse:
        event = cancels.get(bytes(handle.goal_id.uuid))
        if event is not None:
            event.set()
        return CancelResponse.ACCEPT

    group = ReentrantCallbackGroup()
    servers = [  # noqa: F841 (kept alive)
        ActionServer(
            node,
            StateMachine,
            action,
            execute_callback=execute,
            goal_callback=lambda goal: GoalResponse.ACCEPT,
            handle_accepted_callback=lambda handle, report=reports[action]: accepted(handle, report),
            cancel_callback=cancel,
            callback_group=group,
        )
        for action in (*FLOOR_ACTIONS, *DIRECT_ACTIONS)
    ]
    executor = MultiThreadedExecutor(num_threads=8)
    executor.add_node(node)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    threading.Thread(target=executor.spin, daemon=True).start()
    print("ready", flush=True)
    stop.wait()
    executor.shutdown(timeout_sec=1)


def role_floor_controller() -> None:
    """The floor's plain rclpy node: on an event, cancel the goal; when its result comes, send the next.

    Each step runs in the rclpy callback that makes it possible (``rclpy.spin``): the least a
    node can do between the event and the next goal.
    """
    import rclpy
    from cyborg_controller.action import StateMachine
    from rclpy.action import ActionClient
    from rclpy.node import Node
    from std_msgs.msg import String

    rclpy.init()
    node = Node("bench_floor_controller")
    clients = [ActionClient(node, StateMachine, name) for name in FLOOR_ACTIONS]
    for client in clients:
        if not client.wait_for_server(timeout_sec=30):
            raise SystemExit("the floor's action servers did not come up")
    # One thread (rclpy.spin) runs every callback. An event may come before the client has seen
    # its goal accepted (the server's report can overtake the answer): it is then held till then.
    state: dict[str, Any] = {"handle": None, "cancelled": None, "next": "", "held": False, "count": 0}

    def send(event: str) -> None:
        client = clients[state["count"] % 2]
        state["count"] += 1
        state["handle"] = None
        goal = StateMachine.Goal(previous_state="x", event=event, current_state="y")
        client.send_goal_async(goal).add_done_callback(accepted)

    def accepted(future: Any) -> None:
        handle = future.result()
        state["handle"] = handle
        handle.get_result_async().add_done_callback(lambda _: ended(handle))
        if state["held"]:
            state["held"] = False
            cancel()

    def ended(handle: Any) -> None:
        if handle is state["cancelled"]:
            state["cancelled"] = None
            send(state["next"])

    def cancel() -> None:
        state["cancelled"] = state["handle"]
        state["handle"].cancel_goal_async()

    def on_event(message: Any) -> None:
        state["next"] = message.data
        if state["handle"] is None:
            state["held"] = True
        else:
            cancel()

    send("first")
    node.create_subscription(String, FLOOR_EVENT, on_event, 100)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    threading.Thread(target=rclpy.spin, args=(node,), daemon=True).start()
    print("ready", flush=True)
    stop.wait()


# --- the measuring process ---------------------------------------------------------------------


class Reports(StampQueue):
    """Stamps reported by the servers, as (event, stamp) in arrival order."""

    def __init__(self, node: Any, topic: str) -> None:
        from std_msgs.msg import String

        super().__init__()
        self.sub = node.create_subscription(String, topic, self._on, 1000)


class Ours:
    """Events through the controller; latency to the next module's goal accepted."""

    name = "ours"
    waiting_for = "the controller to hear events"

    def __init__(self, node: Any, events: str = REGISTER_EVENT, reports: str = OURS_REPORT) -> None:
        from rclpy.event_handler import PublisherEventCallbacks
        from std_msgs.msg import String

        self.String = String
        self.reports = Reports(node, reports)
        # Our subscription's transient-local half does not take a volatile publisher, by design
        # (docs/ros2.md): rclpy would warn about it, as the module template's publishers do not.
        quiet = PublisherEventCallbacks(incompatible_qos=lambda event: None)
        self.pub = node.create_publisher(String, events, 100, event_callbacks=quiet)
        self.count = 0

    def ready(self) -> None:
        wait_until(lambda: self.pub.get_subscription_count() >= 1, 30, self.waiting_for)
        wait_until(lambda: self.reports.sub.get_publisher_count() >= 1, 30, f"the {self.name} reports")
        self.warm(4)

    def event(self) -> str:
        return "to_b" if self.count % 2 == 0 else "to_a"

    def one(self) -> float:
        event = self.event()
        self.count += 1
        sent = time.perf_counter()
        self.pub.publish(self.String(data=event))
        return (self.reports.next(event) - sent) * 1000

    def warm(self, n: int) -> None:
        time.sleep(0.5)
        self.reports.drain()
        for _ in range(n):
            self.one()


class Floor(Ours):
    """The same hops in plain rclpy: event -> cancel -> CANCELED -> next goal accepted."""

    name = "floor"
    waiting_for = "the floor node to hear events"

    def __init__(self, node: Any) -> None:
        super().__init__(node, FLOOR_EVENT, FLOOR_REPORT)

    def event(self) -> str:
        return f"e{self.count}"


class Direct:
    """Plain rclpy.action in this process, timed from the cancel: cancel, wait CANCELED, next goal
    to the other server, wait accepted (one topic hop short of ours)."""

    name = "direct"

    def __init__(self, node: Any) -> None:
        from cyborg_controller.action import StateMachine
        from rclpy.action import ActionClient

        self.Goal = StateMachine.Goal
        self.reports = Reports(node, DIRECT_REPORT)
        self.clients = [ActionClient(node, StateMachine, name) for name in DIRECT_ACTIONS]
        for client in self.clients:
            if not client.wait_for_server(timeout_sec=30):
                raise SystemExit("the floor's action servers did not come up")
        self.count = 0
        self.handle = self._send()

    def _send(self) -> Any:
        done = threading.Event()
        event = f"d{self.count}"
        client = self.clients[self.count % 2]
        self.count += 1
        future = client.send_goal_async(self.Goal(previous_state="x", event=event, current_state="y"))
        future.add_done_callback(lambda _: done.set())
        if not done.wait(10) or not future.result().accepted:
            raise SystemExit(f"floor goal {event} was not accepted")
        return future.result()

    def ready(self) -> None:
        wait_until(lambda: self.reports.sub.get_publisher_count() >= 1, 30, "the floor's reports")
        time.sleep(0.5)
        self.warm(4)

    def one(self) -> float:
        from action_msgs.msg import GoalStatus

        event = f"d{self.count}"
        start = time.perf_counter()
        ended = threading.Event()
        result = self.handle.get_result_async()
        result.add_done_callback(lambda _: ended.set())
        self.handle.cancel_goal_async()
        if not ended.wait(10) or result.result().status != GoalStatus.STATUS_CANCELED:
            raise SystemExit("floor: the cancel did not end the goal CANCELED")
        self.handle = self._send()
        return (self.reports.next(event) - start) * 1000

    def warm(self, n: int) -> None:
        self.reports.drain()
        for _ in range(n):
            self.one()


ROLES = ("modules", "floor", "controller", "floor_controller")  # in the order they are started


def spawn(role: str, env: dict[str, str]) -> subprocess.Popen[str]:
    child = subprocess.Popen(
        [sys.executable, __file__, "--role", role], env=env, stdout=subprocess.PIPE, text=True
    )
    assert child.stdout is not None
    if child.stdout.readline().strip() != "ready":
        raise SystemExit(f"the {role} process did not start")
    return child


def bench(args: argparse.Namespace) -> dict[str, Any]:
    # ROS 1's generated messages on PYTHONPATH would shadow ROS 2's: the processes get this
    # checkout's code only (without it they would run whatever .venv-ros2 installed).
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    env.setdefault("ROS_DOMAIN_ID", str(random.randint(101, 200)))
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    children: list[subprocess.Popen[str]] = []
    result: dict[str, Any] = {"load": [load()]}
    try:
        for role in ROLES:
            children.append(spawn(role, env))
        rclpy.init()
        node = Node("bench_sender")
        # One thread: its callbacks only note what arrives. rclpy's MultiThreadedExecutor spins
        # while a message waits for a thread of its pool (src/cyborg/transport/ros2/executor.py)
        # and held this process at 80 % of a core: a quiet run then crawled for ten minutes.
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        threading.Thread(target=executor.spin, daemon=True).start()
        contenders: list[Any] = [Ours(node), Floor(node)]
        if not args.no_direct:
            contenders.append(Direct(node))
        for contender in contenders:
            contender.ready()
        started = time.perf_counter()
        cpu_before = {role: cpu_seconds(child.pid) for role, child in zip(ROLES, children, strict=True)}
        result["b2b"] = measure(contenders, args.handovers, args.block, False, args.seed)
        result["b2b_elapsed"] = time.perf_counter() - started
        served = {"floor": args.handovers * (len(contenders) - 1)}
        result["cpu"] = {
            role: (cpu_seconds(child.pid) - cpu_before[role]) * 1000 / served.get(role, args.handovers)
            for role, child in zip(ROLES, children, strict=True)
        }
        result["load"].append(load())
        if args.paced:
            result["paced"] = measure(contenders, args.paced, PACED_BLOCK, True, args.seed + 1)
            result["load"].append(load())
        for child in children:
            if child.poll() is not None:
                raise SystemExit(f"a benchmark process ended early (exit {child.returncode})")
        executor.shutdown(timeout_sec=1)
        return result
    finally:
        for child in reversed(children):
            child.send_signal(signal.SIGINT)
            try:
                child.wait(10)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait(5)


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
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
    parser.add_argument("--role", choices=ROLES, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role is not None:
        {
            "controller": role_controller,
            "modules": role_modules,
            "floor": role_floor,
            "floor_controller": role_floor_controller,
        }[args.role]()
        return
    result = bench(args)
    print(f"machine: {machine_line()}")
    print(
        "load average (1 min) at the start / after back to back / after paced: "
        + " / ".join(f"{value:.1f}" for value in result["load"])
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
        "p50 <= 1.15x floor",
        "event -> cancel -> CANCELED -> next goal accepted",
        "cancel -> CANCELED -> next goal accepted",
    )


if __name__ == "__main__":
    main()
