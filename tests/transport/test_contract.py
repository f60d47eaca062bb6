"""Transport contract: what every transport (embedded, ROS) must do.

The ``graph`` fixture yields a factory of nodes on one transport; the ROS
transport plugs in a second parameter.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from cyborg.errors import ServiceTimeoutError, ServiceUnavailableError, TransportError
from cyborg.transport.base import GoalStatus, MessageInfo, Node, ServerGoalHandle
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


class Graph:
    def __init__(self, clock: Clock, make_node: Callable[[str], Node]) -> None:
        self.clock = clock
        self.node = make_node

    def run(self, coro: Any) -> Any:
        return self.clock.run(coro)


@pytest.fixture(params=["embedded"])
def graph(request: pytest.FixtureRequest) -> Iterator[Graph]:
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    yield Graph(clock, transport.node)
    transport.shutdown()
    clock.close()


def test_topic_delivers_in_order_with_sender(graph: Graph) -> None:
    talker, listener = graph.node("talker"), graph.node("listener")
    got: list[tuple[str, str]] = []
    listener.subscribe("/chat", String, lambda m, i: got.append((m.data, i.sender)))
    pub = talker.publisher("/chat", String)

    async def main() -> None:
        for word in ("a", "b", "c"):
            pub.publish(String(word))
        await graph.clock.sleep(0.1)

    graph.run(main())
    assert got == [("a", "talker"), ("b", "talker"), ("c", "talker")]


def test_relative_names_resolve_to_absolute(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    got: list[str] = []
    b.subscribe("/cyborg_controller/register_event", String, lambda m, i: got.append(m.data))
    a.publisher("cyborg_controller/register_event", String).publish(String("x"))
    graph.run(graph.clock.sleep(0.1))
    assert got == ["x"]


def test_bounded_queue_drops_oldest_and_counts(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    got: list[str] = []
    sub = b.subscribe("/flood", String, lambda m, i: got.append(m.data), queue_size=10)
    pub = a.publisher("/flood", String)
    for n in range(25):
        pub.publish(String(str(n)))
    graph.run(graph.clock.sleep(0.1))
    assert got == [str(n) for n in range(15, 25)]
    assert sub.dropped == 15


def test_messages_are_copies(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    got: list[SystemState] = []
    b.subscribe("/s", SystemState, lambda m, i: got.append(m))
    pub = a.publisher("/s", SystemState)
    msg = SystemState("e", "x", "y")
    pub.publish(msg)
    msg.event = "changed after publish"
    graph.run(graph.clock.sleep(0.1))
    assert got[0].event == "e"


def test_latched_topic_reaches_late_subscriber(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    a.publisher("/latched", String, latch=True).publish(String("last"))
    got: list[str] = []
    graph.run(graph.clock.sleep(0.1))
    b.subscribe("/latched", String, lambda m, i: got.append(m.data))
    graph.run(graph.clock.sleep(0.1))
    assert got == ["last"]


def test_crashing_callback_does_not_stop_delivery(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    got: list[str] = []

    def callback(m: String, i: MessageInfo) -> None:
        if m.data == "boom":
            raise RuntimeError("module bug")
        got.append(m.data)

    b.subscribe("/t", String, callback)
    pub = a.publisher("/t", String)
    pub.publish(String("boom"))
    pub.publish(String("fine"))
    graph.run(graph.clock.sleep(0.1))
    assert got == ["fine"]


def test_type_mismatch_on_a_topic_is_an_error(graph: Graph) -> None:
    a = graph.node("a")
    a.publisher("/typed", String)
    with pytest.raises(TransportError, match="carries std_msgs/String"):
        a.publisher("/typed", SystemState)


def test_service_call_and_sender(graph: Graph) -> None:
    server, client = graph.node("server"), graph.node("client")
    callers: list[str] = []

    def handler(req: Any, info: MessageInfo) -> EmotionalStateServiceResponse:
        callers.append(info.sender)
        return EmotionalStateServiceResponse("happy", 0.5, 0.4, 0.2)

    server.advertise_service("/get", EmotionalStateService, handler)
    proxy = client.service_proxy("/get", EmotionalStateService)
    answer = graph.run(proxy.call(timeout=1.0))
    assert answer.emotional_state == "happy" and callers == ["client"]


def test_service_timeout_and_unavailable(graph: Graph) -> None:
    server, client = graph.node("server"), graph.node("client")

    async def slow(req: Any, info: MessageInfo) -> EmotionalStateServiceResponse:
        await graph.clock.sleep(10)
        return EmotionalStateServiceResponse()

    missing = client.service_proxy("/missing", EmotionalStateService)
    with pytest.raises(ServiceUnavailableError, match="/missing"):
        graph.run(missing.call(timeout=1.0))
    server.advertise_service("/slow", EmotionalStateService, slow)
    with pytest.raises(ServiceTimeoutError, match=r"within 0\.5 s"):
        graph.run(client.service_proxy("/slow", EmotionalStateService).call(timeout=0.5))


def test_parameters_round_trip(graph: Graph) -> None:
    a, b = graph.node("a"), graph.node("b")
    a.set_param("/state_resources", {"base": "cyborg_navigation"})
    assert b.get_param("/state_resources") == {"base": "cyborg_navigation"}
    assert b.get_param("/nothing", "default") == "default"


Handle = ServerGoalHandle[StateMachineGoal, StateMachineResult, StateMachineFeedback]


def _server(node: Node, on_goal: Callable[[Handle], None], on_cancel: Callable[[Handle], None]) -> Any:
    return node.action_server("/mod/act", StateMachineAction, on_goal, on_cancel)


def test_action_goal_feedback_and_success(graph: Graph) -> None:
    mod, ctl = graph.node("mod"), graph.node("ctl")
    senders: list[str] = []

    def on_goal(h: Handle) -> None:
        senders.append(h.sender)
        h.accept()
        h.publish_feedback(StateMachineFeedback("working", h.goal.event))
        graph.clock.call_later(1.0, h.succeed, StateMachineResult("done", "ok"))

    _server(mod, on_goal, lambda h: h.canceled())
    client = ctl.action_client("/mod/act", StateMachineAction)
    feedback: list[str] = []
    statuses: list[GoalStatus] = []

    async def main() -> GoalStatus:
        assert await client.wait_for_server(1.0)
        handle = client.send_goal(
            StateMachineGoal("idle", "go", "mod"),
            on_feedback=lambda f: feedback.append(f.message),
            on_status=statuses.append,
        )
        status = await handle.wait()
        assert handle.result is not None and handle.result.status == "done"
        return status

    assert graph.run(main()) is GoalStatus.SUCCEEDED
    assert feedback == ["go"] and senders == ["ctl"]
    assert statuses == [GoalStatus.ACTIVE, GoalStatus.SUCCEEDED]


def test_action_cancel_active_goal_is_preempted(graph: Graph) -> None:
    mod, ctl = graph.node("mod"), graph.node("ctl")
    cancels: list[str] = []

    def on_cancel(h: Handle) -> None:
        cancels.append(h.goal_id)
        assert h.status is GoalStatus.PREEMPTING
        h.canceled()

    _server(mod, lambda h: h.accept(), on_cancel)
    client = ctl.action_client("/mod/act", StateMachineAction)

    async def main() -> GoalStatus:
        handle = client.send_goal(StateMachineGoal())
        await graph.clock.sleep(0.5)
        assert handle.status is GoalStatus.ACTIVE
        handle.cancel()
        return await handle.wait()

    assert graph.run(main()) is GoalStatus.PREEMPTED
    assert len(cancels) == 1


def test_action_cancel_pending_goal_is_recalled(graph: Graph) -> None:
    mod, ctl = graph.node("mod"), graph.node("ctl")
    _server(mod, lambda h: None, lambda h: h.canceled())  # never accepts
    client = ctl.action_client("/mod/act", StateMachineAction)

    async def main() -> GoalStatus:
        handle = client.send_goal(StateMachineGoal())
        await graph.clock.sleep(0.5)
        handle.cancel()
        return await handle.wait()

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

    _server(mod, on_goal, lambda h: None)
    client = ctl.action_client("/mod/act", StateMachineAction)
    handle = client.send_goal(StateMachineGoal())
    assert graph.run(handle.wait()) is expected
    assert handle.text in ("busy", "failed")


def test_client_notices_server_gone(graph: Graph) -> None:
    mod, ctl = graph.node("mod"), graph.node("ctl")
    _server(mod, lambda h: h.accept(), lambda h: None)
    client = ctl.action_client("/mod/act", StateMachineAction)

    async def main() -> GoalStatus:
        handle = client.send_goal(StateMachineGoal())
        await graph.clock.sleep(0.5)
        mod.shutdown()
        return await handle.wait()

    assert graph.run(main()) is GoalStatus.LOST
    assert not client.server_available()


def test_wait_for_missing_server_times_out(graph: Graph) -> None:
    ctl = graph.node("ctl")
    client = ctl.action_client("/nobody", StateMachineAction)
    start = graph.clock.monotonic()
    assert graph.run(client.wait_for_server(2.0)) is False
    assert graph.clock.monotonic() - start == pytest.approx(2.0, abs=0.06)
