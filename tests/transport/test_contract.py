"""Transport contract: what every transport (embedded, ROS) must do.

The ``graph`` fixture yields a factory of nodes on one transport: ``embedded`` in
virtual time, and ``ros`` on a real roscore in real time, where all nodes live in
this pytest process (one rospy node, ``/cyborg_contract``, shared by the session).
Every test uses its own names (``graph.name``) so that, under ROS, tests never hear
each other. Under ROS a message's sender is the process's node name (the connection
header's caller id), whatever logical node sent it: ``graph.sender(node)``. Under ROS
a publisher must be connected before its messages reach anyone (``graph.connected``)
and an action client must find its server first (``wait_for_server``); the embedded
transport is held to the same code.
"""

from __future__ import annotations

import asyncio
import dataclasses
import itertools
import time
from collections.abc import Awaitable, Callable, Iterator
from typing import Any, TypeVar

import pytest

from cyborg.errors import ServiceTimeoutError, ServiceUnavailableError, TransportError
from cyborg.testing.wait import wait_until
from cyborg.transport.base import (
    ClientGoalHandle,
    GoalStatus,
    MessageInfo,
    Node,
    Publisher,
    ServerGoalHandle,
    Transport,
)
from cyborg.transport.clock import Clock, VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import (
    EmotionalStateService,
    EmotionalStateServiceResponse,
    StateMachineAction,
    StateMachineFeedback,
    StateMachineGoal,
    StateMachineResult,
    String,
    SystemState,
)
from tests.support.ros import ros_session
from tests.support.ros2 import ros2_session

T = TypeVar("T")
_test_numbers = itertools.count(1)
ROS_PATIENCE = 10.0  # real seconds: how long a ROS wait may take before the test fails


class Graph:
    def __init__(
        self,
        clock: Clock,
        transport: Transport,
        make_node: Callable[[str], Node],
        *,
        prefix: str,
        sender: Callable[[str], str],
        ros: bool,
        fresh: Callable[[Clock], Transport],
        kind: str = "",
    ) -> None:
        self.clock = clock
        self.transport = transport
        self.node = make_node
        self.fresh_transport = fresh
        self.prefix = prefix
        self._sender = sender
        self.ros = ros
        self.kind = kind
        """embedded, ros or ros2."""

    def run(self, coro: Awaitable[T]) -> T:
        async def main() -> T:
            return await coro

        return self.clock.run(main())

    def name(self, name: str) -> str:
        """This test's own version of a topic/service/action/parameter name (absolute stays absolute)."""
        return f"/{self.prefix}{name}" if name.startswith("/") else f"{self.prefix}/{name}"

    def sender(self, node: str) -> str:
        """The sender a receiver sees for messages from ``node``."""
        return self._sender(node)

    def timeout(self, seconds: float) -> float:
        """A wait of ``seconds`` (virtual time); under ROS a generous real-time bound instead."""
        return max(seconds, ROS_PATIENCE) if self.ros else seconds

    async def until(self, predicate: Callable[[], bool], what: str, timeout: float = 1.0) -> None:
        assert await wait_until(predicate, self.clock, timeout=self.timeout(timeout)), f"timed out: {what}"

    async def connected(self, publisher: Publisher[Any], subscribers: int = 1) -> None:
        await self.until(lambda: publisher.subscriber_count() >= subscribers, f"{publisher.topic} connected")

    async def wait(self, handle: ClientGoalHandle[Any, Any, Any], timeout: float = 5.0) -> GoalStatus:
        return await asyncio.wait_for(handle.wait(), self.timeout(timeout))

    def node_name(self, name: str) -> str:
        """This test's own version of a node name (for a transport of its own)."""
        return f"{self.prefix}_{name}"

    def busy(self) -> None:
        """Keep the event loop from running while the transport receives (real time under ROS)."""
        if self.ros:
            time.sleep(1.0)


@pytest.fixture(
    params=[
        "embedded",
        pytest.param("ros", marks=pytest.mark.ros),
        pytest.param("ros2", marks=pytest.mark.ros2),
    ]
)
def graph(request: pytest.FixtureRequest) -> Iterator[Graph]:
    prefix = f"contract{next(_test_numbers)}"
    if request.param == "ros2":  # in .venv-ros2 (tests/transport/conftest.py); every node a ROS 2 node
        session2 = ros2_session(request.config)
        made2: list[Node] = []

        def make2(name: str) -> Node:
            node = session2.transport.node(name)
            made2.append(node)
            return node

        def fresh2(clock: Clock) -> Transport:
            from cyborg.transport.ros2 import Ros2Transport

            return Ros2Transport(clock)

        try:
            yield Graph(
                session2.clock,
                session2.transport,
                make2,
                prefix=prefix,
                sender=lambda node: node,
                ros=True,
                kind=request.param,
                fresh=fresh2,
            )
        finally:
            for node in made2:
                node.shutdown()
        return
    if request.param == "embedded":
        clock = VirtualClock()
        embedded = EmbeddedTransport(clock)
        try:
            yield Graph(
                clock,
                embedded,
                embedded.node,
                prefix=prefix,
                sender=lambda node: node,
                ros=False,
                kind=request.param,
                fresh=EmbeddedTransport,
            )
        finally:
            embedded.shutdown()
            clock.close()
        return
    session = ros_session(request.config)
    transport = session.transport
    made: list[Node] = []

    def make(name: str) -> Node:
        node = transport.node(name)
        made.append(node)
        return node

    def fresh(clock: Clock) -> Transport:
        import rospy  # type: ignore[import-not-found]

        from cyborg.transport.ros import RosTransport

        # This process's one rospy node serves the session: a closing transport must not end it.
        request.getfixturevalue("monkeypatch").setattr(rospy, "signal_shutdown", lambda reason: None)
        return RosTransport(clock)

    try:
        yield Graph(
            session.clock,
            transport,
            make,
            prefix=prefix,
            sender=lambda node: transport.ros_name,
            ros=True,
            kind=request.param,
            fresh=fresh,
        )
    finally:
        for node in made:
            node.shutdown()


def test_topic_delivers_in_order_with_sender(graph: Graph) -> None:
    talker, listener = graph.node("talker"), graph.node("listener")
    got: list[tuple[str, str]] = []
    listener.subscribe(graph.name("/chat"), String, lambda m, i: got.append((m.data, i.sender)))
    pub = talker.publisher(graph.name("/chat"), String)

    async def main() -> None:
        await graph.connected(pub)
        for word in ("a", "b", "c"):
            pub.publish(String(word))
        await graph.until(lambda: len(got) >= 3, "three messages")
        await graph.clock.sleep(0.1)

    graph.run(main())
    sender = graph.sender("talker")
    assert got == [("a", sender), ("b", sender), ("c", sender)]


def test_after_waiting_for_connections_the_first_message_reaches_every_subscriber(graph: Graph) -> None:
    talker, listener = graph.node("talker"), graph.node("listener")
    got: list[str] = []
    listener.subscribe(graph.name("/first"), String, lambda m, i: got.append(m.data))
    pub = talker.publisher(graph.name("/first"), String)

    assert graph.transport.wait_for_connections(ROS_PATIENCE) == []
    assert pub.subscriber_count() == 1  # connected now, not some time later
    pub.publish(String("first"))

    async def main() -> None:
        await graph.until(lambda: got == ["first"], "the first message")

    graph.run(main())


def test_relative_names_resolve_to_absolute(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    got: list[str] = []
    b.subscribe(graph.name("/cyborg_controller/register_event"), String, lambda m, i: got.append(m.data))
    pub = a.publisher(graph.name("cyborg_controller/register_event"), String)
    assert pub.topic == graph.name("/cyborg_controller/register_event")

    async def main() -> None:
        await graph.connected(pub)
        pub.publish(String("x"))
        await graph.until(lambda: bool(got), "the event")

    graph.run(main())
    assert got == ["x"]


def test_bounded_queue_drops_oldest_and_counts(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    got: list[str] = []
    sub = b.subscribe(graph.name("/flood"), String, lambda m, i: got.append(m.data), queue_size=10)
    pub = a.publisher(graph.name("/flood"), String)
    graph.run(graph.connected(pub))
    for n in range(25):
        pub.publish(String(str(n)))
    graph.busy()  # the subscriber's loop is busy while all 25 arrive
    graph.run(graph.clock.sleep(0.1))
    assert got == [str(n) for n in range(15, 25)]
    assert sub.dropped == 15


def test_a_published_message_cannot_change(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    got: list[SystemState] = []
    b.subscribe(graph.name("/s"), SystemState, lambda m, i: got.append(m))
    pub = a.publisher(graph.name("/s"), SystemState)
    msg = SystemState("e", "x", "y")

    async def main() -> None:
        await graph.connected(pub)
        pub.publish(msg)
        with pytest.raises(dataclasses.FrozenInstanceError):
            msg.event = "changed after publish"  # type: ignore[misc]
        pub.publish(dataclasses.replace(msg, event="a new message"))
        await graph.until(lambda: len(got) == 2, "the messages")

    graph.run(main())
    assert got == [SystemState("e", "x", "y"), SystemState("a new message", "x", "y")]


def test_latched_topic_reaches_late_subscriber(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    a.publisher(graph.name("/latched"), String, latch=True).publish(String("last"))
    got: list[str] = []
    graph.run(graph.clock.sleep(0.1))
    b.subscribe(graph.name("/latched"), String, lambda m, i: got.append(m.data))

    async def main() -> None:
        await graph.until(lambda: bool(got), "the latched message")
        await graph.clock.sleep(0.1)

    graph.run(main())
    assert got == ["last"]


def test_crashing_callback_does_not_stop_delivery(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    got: list[str] = []

    def callback(m: String, i: MessageInfo) -> None:
        if m.data == "boom":
            raise RuntimeError("module bug")
        got.append(m.data)

    b.subscribe(graph.name("/t"), String, callback)
    pub = a.publisher(graph.name("/t"), String)

    async def main() -> None:
        await graph.connected(pub)
        pub.publish(String("boom"))
        pub.publish(String("fine"))
        await graph.until(lambda: bool(got), "the message after the crash")
        await graph.clock.sleep(0.1)

    graph.run(main())
    assert got == ["fine"]


def test_type_mismatch_on_a_topic_is_an_error(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    a.publisher(graph.name("/typed"), String)
    with pytest.raises(TransportError, match="carries std_msgs/String"):
        a.publisher(graph.name("/typed"), SystemState)
    with pytest.raises(TransportError, match="carries std_msgs/String"):
        b.subscribe(graph.name("/typed"), SystemState, lambda m, i: None)


def test_service_call_and_sender(graph: Graph) -> None:
    server, client = graph.node("server"), graph.node("client")
    callers: list[str] = []

    def handler(req: Any, info: MessageInfo) -> EmotionalStateServiceResponse:
        callers.append(info.sender)
        return EmotionalStateServiceResponse("elated", 0.5, 0.4, 0.2)

    server.advertise_service(graph.name("/get"), EmotionalStateService, handler)
    proxy = client.service_proxy(graph.name("/get"), EmotionalStateService)
    answer = graph.run(proxy.call(timeout=graph.timeout(1.0)))
    assert answer.emotional_state == "elated"  # the PAD values are float32 on the wire
    assert (answer.current_pleasure, answer.current_arousal, answer.current_dominance) == pytest.approx(
        (0.5, 0.4, 0.2), abs=1e-6
    )
    assert callers == [graph.sender("client")]


def test_service_timeout_and_unavailable(graph: Graph) -> None:
    server, client = graph.node("server"), graph.node("client")
    release = asyncio.Event()

    async def slow(req: Any, info: MessageInfo) -> EmotionalStateServiceResponse:
        await release.wait()
        return EmotionalStateServiceResponse()

    missing = client.service_proxy(graph.name("/missing"), EmotionalStateService)
    with pytest.raises(ServiceUnavailableError, match=graph.name("/missing")):
        graph.run(missing.call(timeout=1.0))
    server.advertise_service(graph.name("/slow"), EmotionalStateService, slow)
    slow_proxy = client.service_proxy(graph.name("/slow"), EmotionalStateService)
    assert graph.run(slow_proxy.wait_for_service(graph.timeout(1.0)))
    with pytest.raises(ServiceTimeoutError, match=r"within 0\.5 s"):
        graph.run(slow_proxy.call(timeout=0.5))
    release.set()  # let the handler answer (the late answer goes nowhere)
    graph.run(graph.clock.sleep(0.1))


def test_parameters_round_trip(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    a.set_param(graph.name("/state_resources"), {"base": "cyborg_navigation"})
    assert b.get_param(graph.name("/state_resources")) == {"base": "cyborg_navigation"}
    assert b.get_param(graph.name("/nothing"), "default") == "default"


Handle = ServerGoalHandle[StateMachineGoal, StateMachineResult, StateMachineFeedback]


def _server(
    graph: Graph, node: Node, on_goal: Callable[[Handle], None], on_cancel: Callable[[Handle], None]
) -> Any:
    return node.action_server(graph.name("/mod/act"), StateMachineAction, on_goal, on_cancel)


def _client(graph: Graph, node: Node) -> Any:
    client = node.action_client(graph.name("/mod/act"), StateMachineAction)
    assert graph.run(client.wait_for_server(graph.timeout(1.0))), "the action server was not found"
    return client


def test_action_goal_feedback_and_success(graph: Graph) -> None:
    mod, ctl = graph.node("mod"), graph.node("ctl")
    senders: list[str] = []

    def on_goal(h: Handle) -> None:
        senders.append(h.sender)
        h.accept()
        h.publish_feedback(StateMachineFeedback("working", h.goal.event))
        graph.clock.call_later(1.0, h.succeed, StateMachineResult("done", "ok"))

    _server(graph, mod, on_goal, lambda h: h.canceled())
    client = _client(graph, ctl)
    feedback: list[str] = []
    statuses: list[GoalStatus] = []

    async def main() -> GoalStatus:
        handle = client.send_goal(
            StateMachineGoal("idle", "go", "mod"),
            on_feedback=lambda f: feedback.append(f.message),
            on_status=statuses.append,
        )
        status = await graph.wait(handle)
        assert handle.result == StateMachineResult("done", "ok")
        return status

    assert graph.run(main()) is GoalStatus.SUCCEEDED
    assert feedback == ["go"] and senders == [graph.sender("ctl")]
    assert statuses == [GoalStatus.ACTIVE, GoalStatus.SUCCEEDED]


def test_action_cancel_active_goal_is_preempted(graph: Graph) -> None:
    mod, ctl = graph.node("mod"), graph.node("ctl")
    cancels: list[str] = []
    status_at_cancel: list[GoalStatus] = []

    def on_cancel(h: Handle) -> None:
        cancels.append(h.goal_id)
        status_at_cancel.append(h.status)
        h.canceled()

    _server(graph, mod, lambda h: h.accept(), on_cancel)
    client = _client(graph, ctl)

    async def main() -> GoalStatus:
        handle = client.send_goal(StateMachineGoal())
        await graph.until(lambda: handle.status is GoalStatus.ACTIVE, "the goal active", timeout=0.5)
        handle.cancel()
        return await graph.wait(handle)

    assert graph.run(main()) is GoalStatus.PREEMPTED
    assert len(cancels) == 1 and status_at_cancel == [GoalStatus.PREEMPTING]


def test_action_cancel_pending_goal_is_recalled(graph: Graph) -> None:
    mod, ctl = graph.node("mod"), graph.node("ctl")
    goals: list[Handle] = []
    _server(graph, mod, goals.append, lambda h: h.canceled())  # never accepts
    client = _client(graph, ctl)

    async def main() -> GoalStatus:
        handle = client.send_goal(StateMachineGoal())
        await graph.until(lambda: bool(goals), "the goal at the server", timeout=0.5)
        await graph.clock.sleep(0.1)
        assert handle.status is GoalStatus.PENDING
        handle.cancel()
        return await graph.wait(handle)

    assert graph.run(main()) is GoalStatus.RECALLED


@pytest.mark.parametrize(
    ("verb", "expected"), [("reject", GoalStatus.REJECTED), ("abort", GoalStatus.ABORTED)]
)
def test_action_reject_and_abort(graph: Graph, verb: str, expected: GoalStatus) -> None:
    mod, ctl = graph.node("mod"), graph.node("ctl")

    def on_goal(h: Handle) -> None:
        if verb == "reject":
            h.reject(text="busy")
        else:
            h.accept()
            h.abort(text="failed")

    _server(graph, mod, on_goal, lambda h: None)
    client = _client(graph, ctl)
    handle = client.send_goal(StateMachineGoal())
    assert graph.run(graph.wait(handle)) is expected
    assert handle.text == ("busy" if verb == "reject" else "failed")


def test_client_notices_server_gone(graph: Graph) -> None:
    mod, ctl = graph.node("mod"), graph.node("ctl")
    _server(graph, mod, lambda h: h.accept(), lambda h: None)
    client = _client(graph, ctl)

    async def main() -> GoalStatus:
        handle = client.send_goal(StateMachineGoal())
        await graph.until(lambda: handle.status is GoalStatus.ACTIVE, "the goal active", timeout=0.5)
        mod.shutdown()
        return await graph.wait(handle)

    assert graph.run(main()) is GoalStatus.LOST
    assert not client.server_available()


def test_goal_to_missing_server_is_lost(graph: Graph) -> None:
    ctl = graph.node("ctl")
    client = ctl.action_client(graph.name("/nobody"), StateMachineAction)
    handle = client.send_goal(StateMachineGoal())
    assert graph.run(graph.wait(handle)) is GoalStatus.LOST


def test_wait_for_missing_server_times_out(graph: Graph) -> None:
    ctl = graph.node("ctl")
    client = ctl.action_client(graph.name("/nobody"), StateMachineAction)
    start = graph.clock.monotonic()
    assert graph.run(client.wait_for_server(2.0)) is False
    assert graph.clock.monotonic() - start == pytest.approx(2.0, abs=0.25 if graph.ros else 0.06)


def test_waiting_for_a_server_counts_the_clocks_seconds(graph: Graph) -> None:
    """In process and on ROS 2 the timeout is in the clock's seconds. ROS 1 is the exception: rospy
    and actionlib find a server on their own threads in real time, so a virtual clock's seconds
    (1/25 of a second each at speed 25) would end a state as aborted before the server is seen."""
    clock = VirtualClock()  # as fast as possible: a minute of waiting passes at once
    try:
        with graph.fresh_transport(clock) as transport:
            node = transport.node(graph.node_name("waiter"))
            client = node.action_client(graph.name("/nobody"), StateMachineAction)
            started, real_start = clock.monotonic(), time.monotonic()
            if graph.kind == "ros":
                assert clock.run(client.wait_for_server(1.0)) is False
                assert time.monotonic() - real_start == pytest.approx(1.0, abs=0.5)
                return
            assert clock.run(client.wait_for_server(60.0)) is False
            assert clock.monotonic() - started == pytest.approx(60.0, abs=0.1)
            assert time.monotonic() - real_start < 30.0
    finally:
        clock.close()


def test_on_shutdown_closes_run_once_newest_first(graph: Graph) -> None:
    node = graph.node("closing")
    ran: list[str] = []

    def failing() -> None:
        ran.append("failing")
        raise RuntimeError("a closer's bug")

    node.on_shutdown(lambda: ran.append("first"))
    node.on_shutdown(failing)
    node.on_shutdown(lambda: ran.append("last"))
    assert ran == [] and not node.is_shut_down
    node.shutdown()
    assert ran == ["last", "failing", "first"] and node.is_shut_down
    node.shutdown()
    assert ran == ["last", "failing", "first"], "a second shutdown runs nothing"
    node.on_shutdown(lambda: ran.append("late"))
    assert ran[-1] == "late", "a close given after the shutdown runs at once"
    assert graph.node("closing").name == "closing", "the name is free again"


def test_stats_count_what_the_transport_did(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    stats = graph.transport.stats
    start = dataclasses.replace(stats)
    got: list[str] = []

    async def later(message: String) -> None:
        got.append(message.data)
        raise RuntimeError("a task's bug")

    def callback(message: String, info: MessageInfo) -> Awaitable[None] | None:
        if message.data == "boom":
            raise RuntimeError("a callback's bug")
        if message.data == "task":
            return later(message)  # run as a task
        got.append(message.data)
        return None

    b.subscribe(graph.name("/counted"), String, callback, queue_size=2)
    pub = a.publisher(graph.name("/counted"), String)

    async def failures() -> None:
        await graph.connected(pub)
        pub.publish(String("boom"))
        pub.publish(String("task"))
        await graph.until(lambda: stats.callback_errors - start.callback_errors >= 2, "both failures")

    graph.run(failures())
    for n in range(5):
        pub.publish(String(str(n)))
    graph.busy()  # all five arrive before the loop drains the queue of two
    graph.run(graph.clock.sleep(0.1))
    assert got == ["task", "3", "4"]
    assert graph.transport.stats is stats
    assert dataclasses.asdict(stats) == {
        "callback_errors": start.callback_errors + 2,
        "dropped_messages": start.dropped_messages + 3,
        "published": start.published + 7,
    }


def test_close_shuts_every_node_down_and_refuses_new_ones(graph: Graph) -> None:
    clock = VirtualClock()
    ran: list[str] = []
    try:
        with graph.fresh_transport(clock) as transport:
            name = graph.node_name("closing")
            transport.node(name).on_shutdown(lambda: ran.append("closed"))
            assert transport.node_names() == [name] and ran == []
        assert ran == ["closed"] and transport.node_names() == []
        with pytest.raises(TransportError, match="the transport is closed"):
            transport.node(graph.node_name("late"))
        transport.close()
        assert ran == ["closed"], "a second close does nothing"
    finally:
        clock.close()


def test_a_parallel_state_runs_its_regions_over_the_wire(graph: Graph) -> None:
    """The controller in a parallel state on this transport: both regions' goals at once, an event
    that moves one region only, one state_change per region, the arbitrated resources in
    /state_resources, the muted module on /cyborg_controller/muted, and leaving while both
    modules ignore the cancel: they are waited for together (one preempt timeout, not two)."""
    from cyborg.app.config import parse_config
    from cyborg.controller.runtime import Controller
    from cyborg.transport import topics

    preempt = 1.0
    act = {name: graph.name(f"/par/{name}") for name in ("idle", "a1", "a2", "b1")}
    machine = parse_config(
        f"""
initial: idle
timeouts: {{connect: {graph.timeout(2.0)}, preempt: {preempt}}}
resource_policy: {{speaker: arbitrated}}
states:
  idle: {{action: "{act["idle"]}", transitions: {{go: busy, aborted: idle}}}}
  busy:
    parallel: true
    transitions: {{stop: idle, aborted: idle}}
    states:
      a:
        priority: 1
        states:
          a1: {{action: "{act["a1"]}", resources: {{speaker: a_node}}, transitions: {{flip: a2}}}}
          a2: {{action: "{act["a2"]}"}}
      b:
        priority: 2
        states:
          b1: {{action: "{act["b1"]}", resources: {{speaker: b_node}}}}
"""
    ).machine
    goals: list[tuple[str, float]] = []
    cancels: list[str] = []
    cancelled_at: dict[str, float] = {}
    modules = graph.node("par_modules")
    for name, action in act.items():

        def on_goal(h: Handle, name: str = name) -> None:
            h.accept()
            goals.append((name, graph.clock.monotonic()))

        def on_cancel(h: Handle, name: str = name) -> None:
            cancels.append(name)
            cancelled_at[name] = graph.clock.monotonic()
            if name in ("idle", "a1"):  # a2 and b1 ignore the cancel
                h.canceled()

        modules.action_server(action, StateMachineAction, on_goal, on_cancel)
    observer = graph.node("par_observer")
    changes: list[tuple[str, str, str]] = []
    muted: list[str] = []
    observer.subscribe(
        topics.STATE_CHANGE,
        SystemState,
        lambda m, i: changes.append((m.from_system_state, m.event, m.to_system_state)),
        queue_size=100,
    )
    observer.subscribe(topics.RESOURCE_MUTES, String, lambda m, i: muted.append(m.data), queue_size=100)
    events = observer.publisher(topics.REGISTER_EVENT, String)
    controller = Controller(graph.node("par_controller"), machine)

    async def main() -> float:
        controller.start()
        await graph.until(lambda: [g for g, _ in goals] == ["idle"], "idle's goal", timeout=2.0)
        await graph.connected(events)
        await graph.until(lambda: bool(changes), "the first state change", timeout=2.0)
        events.publish(String("go"))
        await graph.until(lambda: {g for g, _ in goals} == {"idle", "a1", "b1"}, "both regions' goals")
        await graph.until(lambda: len(changes) == 3 and bool(muted), "the changes and the mutes")
        assert changes == [("", "start", "idle"), ("idle", "go", "b1"), ("idle", "go", "a1")]
        assert observer.get_param(topics.STATE_RESOURCES_PARAM) == {"speaker": "b_node"}
        assert '"node": "a_node"' in muted[-1] and '"holder": "b_node"' in muted[-1]
        events.publish(String("flip"))
        await graph.until(lambda: len(goals) == 4, "a2's goal")
        assert goals[-1][0] == "a2" and cancels == ["idle", "a1"], "b1 keeps its goal"
        await graph.until(lambda: len(changes) == 4, "a1 -> a2 published")
        assert changes[-1] == ("a1", "flip", "a2")
        sent = graph.clock.monotonic()
        events.publish(String("stop"))
        await graph.until(
            lambda: goals[-1][0] == "idle" and len(goals) == 5, "idle again", timeout=3 * preempt
        )
        return goals[-1][1] - sent

    try:
        took = graph.run(main())
    finally:
        graph.run(controller.stop())
    assert sorted(cancels[2:4]) == ["a2", "b1"]
    skew = abs(cancelled_at["a2"] - cancelled_at["b1"])
    assert skew < preempt / 2, (
        f"the cancels came {skew:.2f} s apart: one region was waited for before the other"
    )
    assert preempt <= took < 3 * preempt, f"leaving took {took:.2f} s, not the one preempt timeout"
    assert controller.stats.preempt_timeouts == 2
