"""The transport interface every component is written against.

A :class:`Transport` hands out :class:`Node` objects. A node publishes and
subscribes to topics, offers and calls services, offers and uses actions with
actionlib semantics, and reads and writes parameters. Every delivered message
comes with a :class:`MessageInfo` that names the sending node (gatekeepers
filter on it).

Two implementations exist: the in-process :mod:`cyborg.transport.embedded`
(the default, also the test fake) and the ROS 1 transport. All callbacks run on
the clock's event loop, one at a time, so components need no locks.
"""

from __future__ import annotations

import enum
from abc import ABC, abstractmethod
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from cyborg.transport.clock import Clock
from cyborg.transport.messages import ActionType, Message, ServiceType

M = TypeVar("M", bound=Message)
Req = TypeVar("Req", bound=Message)
Resp = TypeVar("Resp", bound=Message)
G = TypeVar("G", bound=Message)
R = TypeVar("R", bound=Message)
F = TypeVar("F", bound=Message)

DEFAULT_QUEUE_SIZE = 100


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
    """Who sent a message, and when (clock time)."""

    sender: str
    stamp: float


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
    topic: str

    @abstractmethod
    def publish(self, message: M) -> None: ...

    @abstractmethod
    def subscriber_count(self) -> int: ...


class Subscription(ABC, Generic[M]):
    topic: str

    @property
    @abstractmethod
    def dropped(self) -> int:
        """Messages dropped because the bounded queue was full."""

    @abstractmethod
    def unsubscribe(self) -> None: ...


class ServiceProxy(ABC, Generic[Req, Resp]):
    name: str

    @abstractmethod
    async def call(self, request: Req | None = None, *, timeout: float = 5.0) -> Resp:
        """Call the service; raises ServiceUnavailableError or ServiceTimeoutError."""

    @abstractmethod
    def available(self) -> bool: ...

    @abstractmethod
    async def wait_for_service(self, timeout: float) -> bool: ...


class ServiceServer(ABC):
    name: str

    @abstractmethod
    def shutdown(self) -> None: ...


class ServerGoalHandle(ABC, Generic[G, R, F]):
    """The server's side of one goal (actionlib's ServerGoalHandle)."""

    goal: G
    goal_id: str
    sender: str

    @property
    @abstractmethod
    def status(self) -> GoalStatus: ...

    @property
    def cancel_requested(self) -> bool:
        return self.status in (GoalStatus.PREEMPTING, GoalStatus.RECALLING)

    @abstractmethod
    def accept(self) -> None: ...

    @abstractmethod
    def reject(self, result: R | None = None, text: str = "") -> None: ...

    @abstractmethod
    def publish_feedback(self, feedback: F) -> None: ...

    @abstractmethod
    def succeed(self, result: R | None = None, text: str = "") -> None: ...

    @abstractmethod
    def abort(self, result: R | None = None, text: str = "") -> None: ...

    @abstractmethod
    def canceled(self, result: R | None = None, text: str = "") -> None:
        """Acknowledge a cancel: PREEMPTED if the goal was active, RECALLED if pending."""


GoalCallback = Callable[[ServerGoalHandle[G, R, F]], None]


class ActionServer(ABC, Generic[G, R, F]):
    name: str

    @abstractmethod
    def shutdown(self) -> None: ...


class ClientGoalHandle(ABC, Generic[G, R, F]):
    """The client's side of one goal."""

    goal: G

    @property
    @abstractmethod
    def status(self) -> GoalStatus: ...

    @property
    @abstractmethod
    def result(self) -> R | None: ...

    @property
    @abstractmethod
    def text(self) -> str: ...

    @abstractmethod
    def cancel(self) -> None: ...

    @abstractmethod
    async def wait(self) -> GoalStatus:
        """Wait until the goal reaches a terminal status and return it."""

    @abstractmethod
    def add_done_callback(self, callback: Callable[[ClientGoalHandle[G, R, F]], None]) -> None: ...


class ActionClient(ABC, Generic[G, R, F]):
    name: str

    @abstractmethod
    def server_available(self) -> bool: ...

    @abstractmethod
    async def wait_for_server(self, timeout: float) -> bool: ...

    @abstractmethod
    def send_goal(
        self,
        goal: G,
        *,
        on_feedback: Callable[[F], None] | None = None,
        on_status: Callable[[GoalStatus], None] | None = None,
    ) -> ClientGoalHandle[G, R, F]: ...


class Node(ABC):
    """One component's handle on the transport (one ROS node under ROS)."""

    name: str
    clock: Clock

    @abstractmethod
    def publisher(
        self,
        topic: str,
        msg_type: type[M],
        *,
        queue_size: int = DEFAULT_QUEUE_SIZE,
        latch: bool = False,
    ) -> Publisher[M]: ...

    @abstractmethod
    def subscribe(
        self,
        topic: str,
        msg_type: type[M],
        callback: Callable[[M, MessageInfo], None],
        *,
        queue_size: int = DEFAULT_QUEUE_SIZE,
    ) -> Subscription[M]: ...

    @abstractmethod
    def advertise_service(
        self,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
    ) -> ServiceServer: ...

    @abstractmethod
    def service_proxy(self, name: str, srv_type: ServiceType[Req, Resp]) -> ServiceProxy[Req, Resp]: ...

    @abstractmethod
    def action_server(
        self,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], None],
    ) -> ActionServer[G, R, F]: ...

    @abstractmethod
    def action_client(self, name: str, action_type: ActionType[G, R, F]) -> ActionClient[G, R, F]: ...

    @abstractmethod
    def get_param(self, name: str, default: Any = None) -> Any: ...

    @abstractmethod
    def set_param(self, name: str, value: Any) -> None: ...

    @abstractmethod
    def shutdown(self) -> None:
        """Withdraw everything this node offers; its action clients see LOST."""

    def resolve(self, name: str) -> str:
        return resolve_name(name, self.name)


class Transport(ABC):
    """Factory of nodes sharing one graph of topics, services, actions and parameters."""

    clock: Clock

    @abstractmethod
    def node(self, name: str) -> Node: ...

    @abstractmethod
    def shutdown(self) -> None: ...

    def close(self) -> None:
        """Shut every node down and leave the graph (over ROS: the process's own node too)."""
        self.shutdown()

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
