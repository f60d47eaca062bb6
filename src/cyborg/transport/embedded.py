"""The embedded in-process transport: the whole robot in one Python process.

Messages, service calls and action traffic are delivered through the clock's
event loop (``call_soon``), never synchronously, so a component sees the same
ordering and re-entrancy as over a network. It is the default transport and the
fake that the tests use; the contract tests run against it and ROS alike.

Messages are frozen (:class:`~cyborg.transport.messages.Message`), so every subscriber gets the
publisher's own object, without a copy. A message type with a mutable field (a list, a dict)
is copied once when published and again for each subscriber that receives it, so no subscriber
can change what another one received, nor the publisher what it sent.
"""

from __future__ import annotations

import asyncio
import copy
import inspect
import itertools
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar, cast

from cyborg.errors import ServiceTimeoutError, ServiceUnavailableError, TransportError
from cyborg.transport._goals import ClientGoal
from cyborg.transport._queue import SubscriptionQueue, check_queue_size
from cyborg.transport.base import (
    DEFAULT_QUEUE_SIZE,
    ActionClient,
    ActionServer,
    ClientGoalHandle,
    F,
    G,
    GoalStatus,
    M,
    MessageInfo,
    Node,
    Publisher,
    R,
    Req,
    Resp,
    ServerGoalHandle,
    ServiceProxy,
    ServiceServer,
    Subscription,
    Transport,
    TransportStats,
)
from cyborg.transport.clock import Clock, RealClock
from cyborg.transport.messages import ActionType, Message, ServiceType, is_immutable

__all__ = ["EmbeddedNode", "EmbeddedTransport", "TransportStats"]  # TransportStats lived here first

log = logging.getLogger(__name__)


T = TypeVar("T")


def _own(message: T) -> T:
    """``message`` itself if it cannot change (frozen), else a deep copy of it."""
    return message if is_immutable(type(message)) else copy.deepcopy(message)  # type: ignore[arg-type]


class _Topic:
    """One topic: its type, its subscriptions and its latched message."""

    def __init__(self, name: str, msg_type: type[Message]) -> None:
        self.name = name
        self.msg_type = msg_type
        self.subscriptions: list[_EmbeddedSubscription[Any]] = []
        self.latched: tuple[Message, MessageInfo] | None = None
        self.immutable = is_immutable(msg_type)


class EmbeddedTransport(Transport):
    """In-process graph of topics, services, actions and parameters.

    Everything it delivers goes through the clock's loop (``call_soon``), never synchronously.
    It keeps no resources beyond its nodes: :meth:`close` only shuts them down.
    """

    def __init__(self, clock: Clock | None = None) -> None:
        """``clock``: a new RealClock when None."""
        super().__init__(clock or RealClock())
        self._topics: dict[str, _Topic] = {}
        self._services: dict[str, _EmbeddedServiceServer[Any, Any]] = {}
        self._action_servers: dict[str, _EmbeddedActionServer[Any, Any, Any]] = {}
        self._action_clients: dict[str, list[_EmbeddedActionClient[Any, Any, Any]]] = {}
        self._params: dict[str, Any] = {}
        self._goal_ids = itertools.count(1)
        self._offer_waiters: set[asyncio.Future[None]] = set()  # woken when a service or action appears

    async def _wait_for_offer(self, is_offered: Callable[[], bool], timeout: float) -> bool:
        """Wait until ``is_offered()`` or ``timeout`` clock seconds pass; no polling."""
        loop = self.clock.loop
        deadline = loop.time() + timeout
        while not is_offered():
            remaining = deadline - loop.time()
            if remaining <= 0:
                return False
            offered = loop.create_future()
            self._offer_waiters.add(offered)
            try:
                await asyncio.wait({offered}, timeout=remaining)
            finally:
                self._offer_waiters.discard(offered)
        return True

    def _offers_changed(self) -> None:
        for waiter in list(self._offer_waiters):
            if not waiter.done():
                waiter.set_result(None)

    # --- nodes ---------------------------------------------------------------

    def node(self, name: str) -> EmbeddedNode:
        """A new in-process node (see :meth:`Transport.node`)."""
        return self._add_node(name, lambda free: EmbeddedNode(self, free))

    # --- topics --------------------------------------------------------------

    def _topic(self, name: str, msg_type: type[Message]) -> _Topic:
        topic = self._topics.get(name)
        if topic is None:
            topic = self._topics[name] = _Topic(name, msg_type)
        elif topic.msg_type is not msg_type:
            raise TransportError(
                f"topic {name} carries {topic.msg_type.ros_type}, not {msg_type.ros_type}: "
                "use the same message type on every publisher and subscriber of a topic"
            )
        return topic

    def topic_names(self) -> dict[str, str]:
        """Every topic used so far, sorted, with its ROS type: ``{"/chat": "std_msgs/String"}``."""
        return {name: t.msg_type.ros_type for name, t in sorted(self._topics.items())}

    def _publish(self, topic: _Topic, message: Message, sender: str, latch: bool) -> None:
        if not isinstance(message, topic.msg_type):
            raise TransportError(
                f"cannot publish {type(message).__name__} on {topic.name}: "
                f"it carries {topic.msg_type.ros_type}"
            )
        self.stats.published += 1
        info = MessageInfo(sender=sender, stamp=self.clock.now())
        if topic.immutable:
            if latch:
                topic.latched = (message, info)
            for subscription in topic.subscriptions:
                subscription._enqueue(message, info)
            return
        sent = copy.deepcopy(message)  # the publisher may change its object afterwards
        if latch:
            topic.latched = (sent, info)
        for subscription in topic.subscriptions:
            subscription._enqueue(copy.deepcopy(sent), info)  # each subscriber its own copy


class EmbeddedNode(Node):
    """A node of the in-process graph; its sender name is its own."""

    def __init__(self, transport: EmbeddedTransport, name: str) -> None:
        super().__init__(transport, name)
        self.transport = transport

    def publisher(
        self,
        topic: str,
        msg_type: type[M],
        *,
        queue_size: int = DEFAULT_QUEUE_SIZE,
        latch: bool = False,
    ) -> Publisher[M]:
        """A publisher on the in-process topic (``queue_size`` unused: nothing waits to go out)."""
        return _EmbeddedPublisher(self, self.transport._topic(self.resolve(topic), msg_type), latch)

    def subscribe(
        self,
        topic: str,
        msg_type: type[M],
        callback: Callable[[M, MessageInfo], Awaitable[None] | None],
        *,
        queue_size: int = DEFAULT_QUEUE_SIZE,
    ) -> Subscription[M]:
        """Subscribe; a latched message waiting on the topic is queued first (see :meth:`Node.subscribe`)."""
        check_queue_size(queue_size)
        t = self.transport._topic(self.resolve(topic), msg_type)
        sub: _EmbeddedSubscription[M] = _EmbeddedSubscription(self.transport, t, callback, queue_size)
        t.subscriptions.append(sub)
        self.on_shutdown(sub.unsubscribe)
        if t.latched is not None:
            latched, info = t.latched
            sub._enqueue(latched if t.immutable else copy.deepcopy(latched), info)
        return sub

    def advertise_service(
        self,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
    ) -> ServiceServer:
        """Offer the service; TransportError if a node of this transport offers it already."""
        full = self.resolve(name)
        if full in self.transport._services:
            raise TransportError(
                f"service {full} is already offered by {self.transport._services[full].node.name}: "
                "each service has one server"
            )
        server: _EmbeddedServiceServer[Req, Resp] = _EmbeddedServiceServer(self, full, srv_type, handler)
        self.transport._services[full] = server
        self.transport._offers_changed()
        self.on_shutdown(server.shutdown)
        return server

    def service_proxy(self, name: str, srv_type: ServiceType[Req, Resp]) -> ServiceProxy[Req, Resp]:
        """A proxy that calls the in-process service ``name``."""
        return _EmbeddedServiceProxy(self, self.resolve(name), srv_type)

    def action_server(
        self,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
    ) -> ActionServer[G, R, F]:
        """Offer the action; TransportError if a node of this transport offers it already."""
        full = self.resolve(name)
        existing = self.transport._action_servers.get(full)
        if existing is not None:
            raise TransportError(
                f"action server {full} already exists in node {existing.node.name}: "
                "give each state's action server its own name"
            )
        server = _EmbeddedActionServer(self, full, action_type, on_goal, on_cancel)
        self.transport._action_servers[full] = server
        self.on_shutdown(server.shutdown)
        self.transport._offers_changed()
        return server

    def action_client(self, name: str, action_type: ActionType[G, R, F]) -> ActionClient[G, R, F]:
        """A client of the in-process action ``name``."""
        full = self.resolve(name)
        client = _EmbeddedActionClient(self, full, action_type)
        self.transport._action_clients.setdefault(full, []).append(client)
        return client

    def get_param(self, name: str, default: Any = None) -> Any:
        """A deep copy of the parameter's value, or ``default``."""
        return copy.deepcopy(self.transport._params.get(self.resolve(name), default))

    def set_param(self, name: str, value: Any) -> None:
        """Keep a deep copy of ``value`` for every node of this transport."""
        self.transport._params[self.resolve(name)] = copy.deepcopy(value)


class _EmbeddedPublisher(Publisher[M]):
    """Publishes on an in-process topic."""

    def __init__(self, node: EmbeddedNode, topic: _Topic, latch: bool) -> None:
        self._node = node
        self._topic = topic
        self._latch = latch
        self.topic = topic.name

    def publish(self, message: M) -> None:
        """Queue ``message`` for each subscription (a copy each, if its type is mutable)."""
        self._node.transport._publish(self._topic, message, self._node.name, self._latch)

    def subscriber_count(self) -> int:
        """Every subscription of the topic: in-process, all are connected."""
        return len(self._topic.subscriptions)


class _EmbeddedSubscription(Subscription[M]):
    """A subscription's bounded queue on an in-process topic."""

    def __init__(
        self,
        transport: EmbeddedTransport,
        topic: _Topic,
        callback: Callable[[M, MessageInfo], Awaitable[None] | None],
        queue_size: int,
    ) -> None:
        self._topic = topic
        self.topic = topic.name
        self._queue = SubscriptionQueue(
            transport.clock, callback, queue_size, transport.run_callback, transport.stats
        )

    @property
    def dropped(self) -> int:
        """Messages dropped because the bounded queue was full."""
        return self._queue.dropped

    def _enqueue(self, message: Message, info: MessageInfo) -> None:
        self._queue.put(cast(M, message), info)

    def unsubscribe(self) -> None:
        """Deliver nothing more and leave the topic."""
        self._queue.close()
        if self in self._topic.subscriptions:
            self._topic.subscriptions.remove(self)


class _EmbeddedServiceServer(ServiceServer, Generic[Req, Resp]):
    """A service offered in-process: its handler answers every proxy of its name."""

    def __init__(
        self,
        node: EmbeddedNode,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
    ) -> None:
        self.node = node
        self.name = name
        self.srv_type = srv_type
        self.handler = handler

    def shutdown(self) -> None:
        """Withdraw the service (if it is still this one)."""
        services = self.node.transport._services
        if services.get(self.name) is self:
            del services[self.name]


class _EmbeddedServiceProxy(ServiceProxy[Req, Resp]):
    """Calls an in-process service's handler on a later loop turn, as over a network."""

    def __init__(self, node: EmbeddedNode, name: str, srv_type: ServiceType[Req, Resp]) -> None:
        self._node = node
        self.name = name
        self._srv_type = srv_type

    def _server(self) -> _EmbeddedServiceServer[Req, Resp] | None:
        return self._node.transport._services.get(self.name)

    def available(self) -> bool:
        """True if a node of this transport offers the service."""
        return self._server() is not None

    async def wait_for_service(self, timeout: float) -> bool:
        """Wait for the service to be offered, woken when it is (no polling)."""
        return await self._node.transport._wait_for_offer(self.available, timeout)

    async def call(self, request: Req | None = None, *, timeout: float = 5.0) -> Resp:
        """Call the handler with a copy of the request (see :meth:`ServiceProxy.call`)."""
        server = self._server()
        if server is None:
            raise ServiceUnavailableError(
                f"service {self.name} is not offered by any node: start the component that offers it"
            )
        if server.srv_type.ros_type != self._srv_type.ros_type:
            raise TransportError(
                f"service {self.name} is {server.srv_type.ros_type}, not {self._srv_type.ros_type}"
            )
        req = request if request is not None else self._srv_type.request()
        info = MessageInfo(sender=self._node.name, stamp=self._node.clock.now())

        async def handle() -> Resp:
            await asyncio.sleep(0)  # deliver on a later loop turn, as over a network
            answer = server.handler(_own(req), info)
            if inspect.isawaitable(answer):
                answer = await answer
            return answer  # type: ignore[return-value]

        try:
            return await asyncio.wait_for(handle(), timeout)
        except TimeoutError as exc:
            raise ServiceTimeoutError(
                f"service {self.name} gave no answer within {timeout} s: "
                "check that its node is running and not blocked, or raise the timeout"
            ) from exc


# --- actions -------------------------------------------------------------------


@dataclass
class _Goal(Generic[G, R, F]):
    """One goal's record, shared by its client and server handles."""

    goal_id: str
    goal: G
    sender: str
    status: GoalStatus = GoalStatus.PENDING
    result: R | None = None
    text: str = ""
    client: _EmbeddedClientGoalHandle[G, R, F] | None = None
    server_handle: _EmbeddedServerGoalHandle[G, R, F] | None = None
    history: list[GoalStatus] = field(default_factory=list)


class _EmbeddedActionServer(ActionServer[G, R, F]):
    """An action offered in-process: it receives goals and cancels on the loop."""

    def __init__(
        self,
        node: EmbeddedNode,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
    ) -> None:
        self.node = node
        self.name = name
        self.action_type = action_type
        self._on_goal = on_goal
        self._on_cancel = on_cancel
        self._goals: dict[str, _Goal[G, R, F]] = {}
        self.alive = True

    def _receive_goal(self, goal: _Goal[G, R, F]) -> None:
        if not self.alive:
            return
        self._goals[goal.goal_id] = goal
        handle = _EmbeddedServerGoalHandle(self, goal)
        goal.server_handle = handle
        self.node.transport.run_callback(self._on_goal, handle)

    def _receive_cancel(self, goal_id: str) -> None:
        goal = self._goals.get(goal_id)
        if goal is None or goal.server_handle is None or goal.status.is_terminal:
            return
        if goal.status is GoalStatus.PENDING:
            self._set_status(goal, GoalStatus.RECALLING)
        elif goal.status is GoalStatus.ACTIVE:
            self._set_status(goal, GoalStatus.PREEMPTING)
        else:
            return
        self.node.transport.run_callback(self._on_cancel, goal.server_handle)

    def _set_status(
        self, goal: _Goal[G, R, F], status: GoalStatus, result: R | None = None, text: str = ""
    ) -> None:
        goal.status = status
        goal.history.append(status)
        if result is not None:
            goal.result = result
        if text:
            goal.text = text
        if status.is_terminal:
            self._goals.pop(goal.goal_id, None)
            if goal.result is None:
                goal.result = self.action_type.result()
        client = goal.client
        if client is not None:
            self.node.clock.loop.call_soon(client.update_status, status, goal.result, goal.text)

    def _send_feedback(self, goal: _Goal[G, R, F], feedback: F) -> None:
        client = goal.client
        if client is not None:
            self.node.clock.loop.call_soon(client.deliver_feedback, _own(feedback))

    def shutdown(self) -> None:
        """Withdraw the action: the goals it holds end LOST at their clients."""
        if not self.alive:
            return
        self.alive = False
        servers = self.node.transport._action_servers
        if servers.get(self.name) is self:
            del servers[self.name]
        for goal in list(self._goals.values()):
            self._goals.pop(goal.goal_id, None)
            if goal.client is not None:
                self.node.clock.loop.call_soon(
                    goal.client.update_status, GoalStatus.LOST, None, "server gone"
                )


_ALLOWED: dict[str, frozenset[GoalStatus]] = {
    "accept": frozenset({GoalStatus.PENDING, GoalStatus.RECALLING}),
    "reject": frozenset({GoalStatus.PENDING, GoalStatus.RECALLING}),
    "finish": frozenset({GoalStatus.ACTIVE, GoalStatus.PREEMPTING}),
    "canceled": frozenset(
        {GoalStatus.PENDING, GoalStatus.ACTIVE, GoalStatus.PREEMPTING, GoalStatus.RECALLING}
    ),
}


class _EmbeddedServerGoalHandle(ServerGoalHandle[G, R, F]):
    """The server's side of one in-process goal; a call its status forbids is logged and ignored."""

    def __init__(self, server: _EmbeddedActionServer[G, R, F], goal: _Goal[G, R, F]) -> None:
        self._server = server
        self._goal = goal
        self.goal = goal.goal
        self.goal_id = goal.goal_id
        self.sender = goal.sender

    @property
    def status(self) -> GoalStatus:
        """The goal's status."""
        return self._goal.status

    def _transition(self, kind: str, status: GoalStatus, result: R | None, text: str) -> None:
        if self._goal.status not in _ALLOWED[kind]:
            log.warning(
                "action %s: cannot %s goal %s in status %s; ignored",
                self._server.name,
                kind,
                self.goal_id,
                self._goal.status.name,
            )
            return
        self._server._set_status(self._goal, status, result, text)

    def accept(self) -> None:
        """PENDING -> ACTIVE (RECALLING -> PREEMPTING: the cancel still stands)."""
        target = GoalStatus.PREEMPTING if self._goal.status is GoalStatus.RECALLING else GoalStatus.ACTIVE
        self._transition("accept", target, None, "")

    def reject(self, result: R | None = None, text: str = "") -> None:
        """End a goal not yet accepted REJECTED."""
        self._transition("reject", GoalStatus.REJECTED, result, text)

    def publish_feedback(self, feedback: F) -> None:
        """Send feedback to the client's ``on_feedback`` on a later loop turn."""
        if not self._goal.status.is_terminal:
            self._server._send_feedback(self._goal, feedback)

    def succeed(self, result: R | None = None, text: str = "") -> None:
        """End an accepted goal SUCCEEDED."""
        self._transition("finish", GoalStatus.SUCCEEDED, result, text)

    def abort(self, result: R | None = None, text: str = "") -> None:
        """End an accepted goal ABORTED."""
        self._transition("finish", GoalStatus.ABORTED, result, text)

    def canceled(self, result: R | None = None, text: str = "") -> None:
        """Acknowledge a cancel: RECALLED if pending, PREEMPTED if active."""
        pending = self._goal.status in (GoalStatus.PENDING, GoalStatus.RECALLING)
        target = GoalStatus.RECALLED if pending else GoalStatus.PREEMPTED
        self._transition("canceled", target, result, text)


class _EmbeddedClientGoalHandle(ClientGoal[G, R, F]):
    """The client's side of one in-process goal: a cancel reaches the server on a later loop turn."""

    def __init__(
        self,
        client: _EmbeddedActionClient[G, R, F],
        goal: _Goal[G, R, F],
        on_feedback: Callable[[F], Awaitable[None] | None] | None,
        on_status: Callable[[GoalStatus], Awaitable[None] | None] | None,
    ) -> None:
        transport = client._node.transport
        super().__init__(
            goal.goal,
            clock=client._node.clock,
            run=transport.run_callback,
            on_feedback=on_feedback,
            on_status=on_status,
        )
        self._client = client
        self._goal = goal

    def _request_cancel(self) -> None:
        server = self._client._server()
        if server is None:
            return
        self._client._node.clock.loop.call_soon(server._receive_cancel, self._goal.goal_id)


class _EmbeddedActionClient(ActionClient[G, R, F]):
    """Sends goals to the in-process action server of its name."""

    def __init__(self, node: EmbeddedNode, name: str, action_type: ActionType[G, R, F]) -> None:
        self._node = node
        self.name = name
        self._action_type = action_type

    def _server(self) -> _EmbeddedActionServer[G, R, F] | None:
        server = self._node.transport._action_servers.get(self.name)
        if server is None or not server.alive:
            return None
        if server.action_type.ros_type != self._action_type.ros_type:
            raise TransportError(
                f"action {self.name} is {server.action_type.ros_type}, "
                f"not {self._action_type.ros_type}: use the server's action type"
            )
        return cast(_EmbeddedActionServer[G, R, F], server)

    def server_available(self) -> bool:
        """True if a node offers the action; TransportError if with another action type."""
        return self._server() is not None

    async def wait_for_server(self, timeout: float) -> bool:
        """Wait for the server to be offered, woken when it is (no polling)."""
        return await self._node.transport._wait_for_offer(self.server_available, timeout)

    def send_goal(
        self,
        goal: G,
        *,
        on_feedback: Callable[[F], Awaitable[None] | None] | None = None,
        on_status: Callable[[GoalStatus], Awaitable[None] | None] | None = None,
    ) -> ClientGoalHandle[G, R, F]:
        """Send a copy of ``goal``; it reaches the server on a later loop turn (see :meth:`ActionClient.send_goal`)."""
        transport = self._node.transport
        record: _Goal[G, R, F] = _Goal(
            goal_id=f"{self._node.name}-{next(transport._goal_ids)}",
            goal=_own(goal),
            sender=self._node.name,
        )
        handle = _EmbeddedClientGoalHandle(self, record, on_feedback, on_status)
        record.client = handle
        server = self._server()
        loop = self._node.clock.loop
        if server is None:
            loop.call_soon(handle.update_status, GoalStatus.LOST, None, f"no action server at {self.name}")
        else:
            loop.call_soon(server._receive_goal, record)
        return handle
