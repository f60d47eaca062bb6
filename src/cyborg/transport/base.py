"""The transport interface every component is written against, and the contract it keeps.

A :class:`Transport` hands out :class:`Node` objects. A node publishes and subscribes to
topics, offers and calls services, offers and uses actions with actionlib's semantics, and
reads and writes parameters. Every delivered message comes with a :class:`MessageInfo` that
names the sending node (gatekeepers filter on it).

Three implementations exist: the in-process :mod:`cyborg.transport.embedded` (the default,
also the test fake), the ROS 1 transport (:mod:`cyborg.transport.ros`) and the ROS 2 transport
(:mod:`cyborg.transport.ros2`). ``tests/transport/test_contract.py`` holds all three to what
this module says.

Threads and order, on every transport:

* Every callback a component gives (a subscription's callback, a service handler, an action
  server's ``on_goal`` and ``on_cancel``, a goal's ``on_status``, ``on_feedback`` and done
  callbacks) runs on the clock's event loop, one at a time, so components need no locks. None
  runs inside the call that caused it: ``publish``, ``send_goal`` or ``accept`` return first.
* A callback that returns an awaitable has it run as a task; the transport does not wait for
  it, so the next callback may run before it finishes. (A service handler's awaitable is
  awaited instead: its result is the response.)
* A callback (or its task) that raises is logged and counted in :attr:`Transport.stats`;
  delivery carries on. (A service handler's failure goes to its caller instead.)
* Call the methods of a transport, its nodes and what they hand out from the loop's thread.
  ROS delivers on threads of its own and hands every callback to the loop
  (:meth:`Transport.to_loop`).

Errors are :class:`~cyborg.errors.TransportError` or its subclasses, each naming the bad value
and the fix.
"""

from __future__ import annotations

import asyncio
import enum
import logging
from abc import ABC, abstractmethod
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from typing import Any, Generic, Self, TypeVar

from cyborg.errors import TransportError
from cyborg.transport._callbacks import CallbackRunner
from cyborg.transport.clock import Clock
from cyborg.transport.messages import ActionType, Message, ServiceType

M = TypeVar("M", bound=Message)
Req = TypeVar("Req", bound=Message)
Resp = TypeVar("Resp", bound=Message)
G = TypeVar("G", bound=Message)
R = TypeVar("R", bound=Message)
F = TypeVar("F", bound=Message)
_N = TypeVar("_N", bound="Node")

DEFAULT_QUEUE_SIZE = 100

log = logging.getLogger(__name__)


class GoalStatus(enum.IntEnum):
    """actionlib goal statuses (same numbers as ``actionlib_msgs/GoalStatus``)."""

    PENDING = 0
    ACTIVE = 1
    PREEMPTED = 2
    SUCCEEDED = 3
    ABORTED = 4
    REJECTED = 5
    PREEMPTING = 6
    RECALLING = 7
    RECALLED = 8
    LOST = 9

    @property
    def is_terminal(self) -> bool:
        """True for a status a goal never leaves (PREEMPTED, SUCCEEDED, ABORTED, REJECTED, RECALLED, LOST)."""
        return self in _TERMINAL


_TERMINAL = frozenset(
    {
        GoalStatus.PREEMPTED,
        GoalStatus.SUCCEEDED,
        GoalStatus.ABORTED,
        GoalStatus.REJECTED,
        GoalStatus.RECALLED,
        GoalStatus.LOST,
    }
)


@dataclass(frozen=True)
class MessageInfo:
    """Who sent a message, and when.

    ``sender`` is the sending node's name without the leading slash: the logical node on the
    embedded and ROS 2 transports, the process's one rospy node on ROS 1, and ``''`` when the
    transport cannot tell (a gatekeeper drops such a message). ``stamp`` is the clock's
    :meth:`~cyborg.transport.clock.Clock.now` when the embedded transport delivers it, and
    the wall-clock time of its arrival over ROS.
    """

    sender: str
    stamp: float


@dataclass
class TransportStats:
    """What a transport did since it was made: counters that only grow. Read them; do not write them."""

    callback_errors: int = 0
    """Callbacks, or the tasks they returned, that raised (each is logged)."""
    dropped_messages: int = 0
    """Messages a full subscription queue dropped (its oldest), over all subscriptions."""
    published: int = 0
    """Messages given to :meth:`Publisher.publish`, once each, whatever the number of subscribers."""


def normalize_node_name(name: str) -> str:
    """Node names without the leading slash: ``/cyborg_navigation`` -> ``cyborg_navigation``."""
    return name.strip().lstrip("/")


def resolve_name(name: str, node_name: str) -> str:
    """Resolve a topic/service/action name to its absolute form, as ROS 1 does."""
    name = name.strip()
    if name.startswith("~"):
        return "/" + normalize_node_name(node_name) + "/" + name[1:].lstrip("/")
    return name if name.startswith("/") else "/" + name


class Publisher(ABC, Generic[M]):
    """Sends messages of one type on one topic (made by :meth:`Node.publisher`)."""

    topic: str
    """The topic's absolute name."""

    @abstractmethod
    def publish(self, message: M) -> None:
        """Send ``message`` to every subscription of the topic, and return at once.

        Each subscription receives it on a later loop turn, after the messages this publisher
        sent before it. Messages are frozen, so a subscriber can neither change what another
        one received nor the publisher what it sent. A latched publisher also keeps it for
        every later subscription (:meth:`Node.publisher`). Over ROS, a subscriber that is not
        connected yet misses it (:meth:`Transport.wait_for_connections`).

        Raises TransportError for a message of another type (embedded transport). Do not
        publish after the node shut down: transports differ in what that does.
        """

    @abstractmethod
    def subscriber_count(self) -> int:
        """The subscriptions this publisher reaches now: in-process, every subscription of the
        topic; over ROS, those connected to it so far."""

    def wait_delivered(self, timeout: float) -> bool:
        """Block up to ``timeout`` real seconds until every subscription it reaches has taken
        what it published (ROS 2: acknowledged it); True when all did. For a process about to
        leave the graph (the command tool). In-process and on ROS 1 it returns True at once."""
        return True


class Subscription(ABC, Generic[M]):
    """One callback's subscription to a topic (made by :meth:`Node.subscribe`)."""

    topic: str
    """The topic's absolute name."""

    @property
    @abstractmethod
    def dropped(self) -> int:
        """Messages dropped because the bounded queue was full."""

    @abstractmethod
    def unsubscribe(self) -> None:
        """Deliver nothing more: what waits in the queue is discarded, and what arrives later too."""


class ServiceProxy(ABC, Generic[Req, Resp]):
    """Calls one service (made by :meth:`Node.service_proxy`); making it does not wait for a server."""

    name: str
    """The service's absolute name."""

    @abstractmethod
    async def call(self, request: Req | None = None, *, timeout: float = 5.0) -> Resp:
        """Send ``request`` (None: the request type's defaults) and return the server's response.

        The handler runs on the server's loop; this waits, without blocking the loop, up to
        ``timeout`` clock seconds. When the handler raises, the caller gets its exception
        (embedded), a TransportError (ROS 1) or the response type's defaults (ROS 2).

        Raises ServiceUnavailableError when no server offers the service now (wait for one
        with :meth:`wait_for_service` first), ServiceTimeoutError when the answer does not come
        within ``timeout``, and TransportError when the service failed or has another type.
        """

    @abstractmethod
    def available(self) -> bool:
        """True if a server offers the service now (ROS 1 asks the master, blocking up to 0.05 s)."""

    @abstractmethod
    async def wait_for_service(self, timeout: float) -> bool:
        """Wait until a server offers the service, up to ``timeout`` seconds (clock seconds; ROS 1:
        real seconds); True if one does."""


class ServiceServer(ABC):
    """One offered service (made by :meth:`Node.advertise_service`)."""

    name: str
    """The service's absolute name."""

    @abstractmethod
    def shutdown(self) -> None:
        """Withdraw the service: later calls find no server. Its node's shutdown does this too."""


class ServerGoalHandle(ABC, Generic[G, R, F]):
    """The server's side of one goal (actionlib's ServerGoalHandle), given to ``on_goal``.

    The module decides with :meth:`accept` or :meth:`reject`, then ends an accepted goal with
    :meth:`succeed`, :meth:`abort` or, after a cancel, :meth:`canceled`. Each call takes effect
    at once here and reaches the client on a later loop turn. A call the goal's status does not
    allow (ending a goal twice, accepting a finished one) is ignored and may be logged.
    """

    goal: G
    """The goal message the client sent."""
    goal_id: str
    """The goal's id, unique on the graph."""
    sender: str
    """The node that sent the goal, as in :attr:`MessageInfo.sender`."""

    @property
    @abstractmethod
    def status(self) -> GoalStatus:
        """The goal's status as this server knows it."""

    @property
    def cancel_requested(self) -> bool:
        """True once the client asked to cancel and the goal is not finished (PREEMPTING or RECALLING)."""
        return self.status in (GoalStatus.PREEMPTING, GoalStatus.RECALLING)

    @abstractmethod
    def accept(self) -> None:
        """Take on a PENDING goal: it becomes ACTIVE."""

    @abstractmethod
    def reject(self, result: R | None = None, text: str = "") -> None:
        """Refuse a goal not accepted yet: it ends REJECTED with ``result`` and ``text``."""

    @abstractmethod
    def publish_feedback(self, feedback: F) -> None:
        """Send ``feedback`` to the client's ``on_feedback``; nothing once the goal is finished."""

    @abstractmethod
    def succeed(self, result: R | None = None, text: str = "") -> None:
        """End an accepted goal SUCCEEDED (``result`` None: the result type's defaults)."""

    @abstractmethod
    def abort(self, result: R | None = None, text: str = "") -> None:
        """End an accepted goal ABORTED (``result`` None: the result type's defaults)."""

    @abstractmethod
    def canceled(self, result: R | None = None, text: str = "") -> None:
        """Acknowledge a cancel: PREEMPTED if the goal was active, RECALLED if pending."""


GoalCallback = Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None]
"""An action server's ``on_goal`` or ``on_cancel``."""


class ActionServer(ABC, Generic[G, R, F]):
    """One offered action (made by :meth:`Node.action_server`)."""

    name: str
    """The action's absolute name."""

    @abstractmethod
    def shutdown(self) -> None:
        """Withdraw the action: goals it still holds end LOST at their clients, and later goals
        find no server. Its node's shutdown does this too."""


class ClientGoalHandle(ABC, Generic[G, R, F]):
    """The client's side of one goal (returned by :meth:`ActionClient.send_goal`).

    It starts PENDING and follows what the server reports, on the loop, until a terminal
    status; after that nothing about it changes.
    """

    goal: G
    """The goal message as sent."""

    @property
    @abstractmethod
    def status(self) -> GoalStatus:
        """The goal's status as last reported to this client."""

    @property
    @abstractmethod
    def result(self) -> R | None:
        """The server's result once the goal is finished (None before, and when LOST)."""

    @property
    @abstractmethod
    def text(self) -> str:
        """The server's status text once the goal is finished (``reject(text=...)``), else ''."""

    @abstractmethod
    def cancel(self) -> None:
        """Ask the server to cancel the goal; nothing once it is finished.

        The goal ends PREEMPTED (it was active) or RECALLED (still pending) when the server
        acknowledges with :meth:`ServerGoalHandle.canceled`; the server may also end it otherwise.
        """

    @abstractmethod
    async def wait(self) -> GoalStatus:
        """Wait until the goal reaches a terminal status and return it."""

    @abstractmethod
    def add_done_callback(self, callback: Callable[[ClientGoalHandle[G, R, F]], None]) -> None:
        """Call ``callback(handle)`` once, on the loop, when the goal reaches a terminal status.

        If it already has, the callback runs on a later loop turn with ``call_soon``: then a
        failure goes to the loop's exception handler, uncounted, and an awaitable is not run.
        """


class ActionClient(ABC, Generic[G, R, F]):
    """Sends goals to one action (made by :meth:`Node.action_client`); making it does not wait for a server."""

    name: str
    """The action's absolute name."""

    @abstractmethod
    def server_available(self) -> bool:
        """True if a server offers the action now and a goal sent now would reach it."""

    @abstractmethod
    async def wait_for_server(self, timeout: float) -> bool:
        """Wait until :meth:`server_available`, up to ``timeout`` clock seconds; True if it is."""

    @abstractmethod
    def send_goal(
        self,
        goal: G,
        *,
        on_feedback: Callable[[F], Awaitable[None] | None] | None = None,
        on_status: Callable[[GoalStatus], Awaitable[None] | None] | None = None,
    ) -> ClientGoalHandle[G, R, F]:
        """Send ``goal`` and return its handle at once, PENDING.

        ``on_status`` is called with every status the goal takes after PENDING, the terminal one
        last; ``on_feedback`` with every feedback the server publishes before the goal finishes.
        When no server is available now the goal ends LOST on a later loop turn; when the server
        goes away while the goal runs it ends LOST too (over ROS within about a second).
        """


class Node(ABC):
    """One component's handle on the transport (one ROS node under ROS).

    Names of topics, services, actions and parameters are resolved as ROS 1 does
    (:meth:`resolve`). Whatever the node makes is withdrawn when it shuts down
    (:meth:`shutdown`); a transport adds each such withdrawal with :meth:`on_shutdown`.
    """

    name: str
    """The node's name, without the leading slash; unique in its transport."""
    clock: Clock
    """The transport's clock: its loop runs every callback."""

    def __init__(self, transport: Transport, name: str) -> None:
        """An implementation calls this first, with the name :meth:`Transport.node` checked."""
        self.name = name
        self.clock = transport.clock
        self._transport = transport
        self._closers: list[Callable[[], None]] | None = []  # None once shut down

    @abstractmethod
    def publisher(
        self,
        topic: str,
        msg_type: type[M],
        *,
        queue_size: int = DEFAULT_QUEUE_SIZE,
        latch: bool = False,
    ) -> Publisher[M]:
        """A publisher of ``msg_type`` on ``topic``.

        ``latch``: the last message published is kept, and every later subscription receives it
        first (while the publisher lives; the embedded transport keeps it for its own life).
        ``queue_size``: how many outgoing messages ROS may buffer (the embedded transport has no
        outgoing queue). Raises TransportError when the topic carries another type.
        """

    @abstractmethod
    def subscribe(
        self,
        topic: str,
        msg_type: type[M],
        callback: Callable[[M, MessageInfo], Awaitable[None] | None],
        *,
        queue_size: int = DEFAULT_QUEUE_SIZE,
    ) -> Subscription[M]:
        """Call ``callback(message, info)`` for every message on ``topic`` from now on.

        Messages wait in a queue of ``queue_size`` drained on the loop, in the order each
        publisher sent them; when it is full the oldest is dropped and counted
        (:attr:`Subscription.dropped`, :attr:`TransportStats.dropped_messages`). A latched
        message comes first. Raises TransportError when the topic carries another type or
        ``queue_size`` is below 1.
        """

    @abstractmethod
    def advertise_service(
        self,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
    ) -> ServiceServer:
        """Offer the service ``name``: ``handler(request, info)`` answers each call, on the loop.

        An awaitable the handler returns is awaited, and its result is the response. Raises
        TransportError when this transport already offers a service of that name (embedded).
        """

    @abstractmethod
    def service_proxy(self, name: str, srv_type: ServiceType[Req, Resp]) -> ServiceProxy[Req, Resp]:
        """A proxy that calls the service ``name`` (which need not be offered yet)."""

    @abstractmethod
    def action_server(
        self,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
    ) -> ActionServer[G, R, F]:
        """Offer the action ``name``: ``on_goal(handle)`` for each new goal, ``on_cancel(handle)``
        when its client asks to cancel it (the handle is then PREEMPTING or RECALLING).

        Raises TransportError when this transport already has a server of that name (embedded).
        """

    @abstractmethod
    def action_client(self, name: str, action_type: ActionType[G, R, F]) -> ActionClient[G, R, F]:
        """A client of the action ``name`` (whose server need not exist yet).

        Raises TransportError when the server has another action type (when a goal is sent).
        """

    @abstractmethod
    def get_param(self, name: str, default: Any = None) -> Any:
        """The parameter's value (a copy), or ``default`` when it is unset.

        Raises TransportError when the parameters cannot be read (the ROS master or the ROS 2
        parameter home does not answer).
        """

    @abstractmethod
    def set_param(self, name: str, value: Any) -> None:
        """Set the parameter to a copy of ``value``, for every node of the graph.

        Raises TransportError when the ROS 2 parameter home refuses or does not answer; the ROS
        1 transport sets it again once an absent master is back.
        """

    def on_shutdown(self, close: Callable[[], None]) -> None:
        """Call ``close()`` when this node shuts down; at once if it has shut down already.

        A transport hands every subscription, server and client it makes to this. At shutdown
        the ``close`` callables run newest first, each once; one that raises is logged and the
        others still run.
        """
        if self._closers is None:
            self._close_one(close)
        else:
            self._closers.append(close)

    @property
    def is_shut_down(self) -> bool:
        """True once :meth:`shutdown` was called."""
        return self._closers is None

    def shutdown(self) -> None:
        """Withdraw everything this node made; a second call does nothing.

        Its subscriptions deliver nothing more, its services and action servers are gone (the
        goals they held end LOST at their clients), and the :meth:`on_shutdown` callables run,
        newest first. Then its name is free again. What becomes of goals the node's own action
        clients sent differs between transports. Nothing here raises.
        """
        closers, self._closers = self._closers, None
        for close in reversed(closers or []):
            self._close_one(close)
        self._transport._forget_node(self)

    def _close_one(self, close: Callable[[], None]) -> None:
        try:
            close()
        except Exception:
            log.debug("node %s: closing %r failed", self.name, close, exc_info=True)

    def resolve(self, name: str) -> str:
        """``name`` made absolute for this node (:func:`resolve_name`): ``~x`` -> ``/<node>/x``."""
        return resolve_name(name, self.name)


class Transport(ABC):
    """Factory of nodes sharing one graph of topics, services, actions and parameters.

    Close it when done, or use it as a context manager (``with EmbeddedTransport() as t:``),
    which closes it on exit.
    """

    clock: Clock
    """The injected clock, whose loop runs every callback."""

    def __init__(self, clock: Clock) -> None:
        """An implementation calls this first; its :meth:`node` hands the checks to ``_add_node``."""
        self.clock = clock
        self._stats = TransportStats()
        self._nodes: dict[str, Node] = {}
        self._closed = False
        # The implementation's own logger names a failing callback's transport.
        self.run_callback = CallbackRunner(
            logging.getLogger(type(self).__module__), self._count_callback_error
        )
        """Runs a component's callback now, on the loop: logs and counts its failure, and runs an
        awaitable it returns as a task. A transport calls back through it (service handlers aside)."""

    @property
    def stats(self) -> TransportStats:
        """What this transport did so far (the same object, updated as it works)."""
        return self._stats

    def _count_callback_error(self) -> None:
        self._stats.callback_errors += 1

    @abstractmethod
    def node(self, name: str) -> Node:
        """A new node named ``name`` (a leading slash is dropped).

        Raises TransportError when the name is empty or already used by a node of this
        transport that has not shut down, or when the transport is closed.
        """

    def _add_node(self, name: str, make: Callable[[str], _N]) -> _N:
        """``make(name)`` under the normalised ``name``, after the checks :meth:`node` promises."""
        name = normalize_node_name(name)
        if self._closed:
            raise TransportError(
                f"cannot make node {name!r}: the transport is closed; fix: make a new transport"
            )
        if not name:
            raise TransportError("node name is empty: give every component a name, e.g. 'cyborg_idle'")
        if name in self._nodes:
            raise TransportError(
                f"node name {name!r} is already in use in this transport: node names must be unique, "
                "pick another"
            )
        node = make(name)
        self._nodes[name] = node
        return node

    def _forget_node(self, node: Node) -> None:
        if self._nodes.get(node.name) is node:
            del self._nodes[node.name]

    def node_names(self) -> list[str]:
        """The names of this transport's nodes that have not shut down, sorted."""
        return sorted(self._nodes)

    def shutdown(self) -> None:
        """Shut down every node (:meth:`Node.shutdown`). The transport stays usable: new nodes may be made."""
        for node in list(self._nodes.values()):
            node.shutdown()

    def close(self) -> None:
        """Shut down every node, then let go of the middleware (ROS: leave the graph).

        After it, :meth:`node` raises TransportError; a second call does nothing.
        """
        if self._closed:
            return
        self._closed = True
        self.shutdown()
        self._leave()

    def _leave(self) -> None:  # noqa: B027 - a hook: in-process there is nothing more to release
        """What :meth:`close` releases beyond the nodes, once: the middleware's context."""

    def __enter__(self) -> Self:
        """The transport itself."""
        return self

    def __exit__(self, *exc_info: object) -> None:
        """:meth:`close` it, whether the block raised or not."""
        self.close()

    def to_loop(self, callback: Callable[..., object], *args: Any) -> None:
        """Run ``callback(*args)`` through :attr:`run_callback` on the loop, from any thread: how a
        middleware's own threads deliver (or the loop itself, when it reads the middleware: on a later
        turn, without waking it). Once the loop is closed, it is dropped."""
        loop = self.clock.loop
        if asyncio._get_running_loop() is loop:
            loop.call_soon(self.run_callback, callback, *args)
        elif not loop.is_closed():
            loop.call_soon_threadsafe(self.run_callback, callback, *args)

    def arrive(
        self,
        channel: str,
        sender: str,
        callback: Callable[..., object],
        *args: Any,
        counted: Sequence[str] = (),
    ) -> None:
        """A message on ``channel`` from ``sender`` arrived on a middleware's thread: run
        ``callback(*args)`` as :meth:`to_loop` does, or, with lockstep time, in the next delta
        cycle (:meth:`Clock.deliver`), counting the channels in ``counted`` as received."""
        if self.clock.is_lockstep:
            self.clock.deliver(channel, sender, self.run_callback, callback, *args, counted=counted)
        else:
            self.to_loop(callback, *args)

    def wait_for_connections(self, timeout: float) -> list[str]:
        """Wait up to ``timeout`` real seconds until this process's topics are connected to every
        publisher and subscriber the graph lists on them; return the connections still missing
        (``"talker -> listener on /topic"``), empty when all are made.

        Over ROS a subscriber is connected to a publisher some time after both exist, and what is
        published before is lost to it: a node calls this before it starts its work, so that its
        first messages reach everyone. In-process every subscriber receives from the moment it
        subscribes: nothing to wait for.
        """
        return []
