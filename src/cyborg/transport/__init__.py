"""Transport layer: the interface components are written against, and three implementations.

- :mod:`~cyborg.transport.base`: the interface (:class:`Transport`, :class:`Node`, topics,
  services, actions, parameters), its contract written on each member;
- :mod:`~cyborg.transport.clock`: the injected clock (real, or virtual time that runs a day in
  seconds); :mod:`~cyborg.transport.lockstep`: a node's side of virtual time granted across
  processes, and :mod:`~cyborg.transport.ledger`: what it counts; :mod:`~cyborg.transport.messages`
  and :mod:`~cyborg.transport.topics`: the thesis's messages and names;
  :mod:`~cyborg.transport.graph`: what a ROS graph holds at one moment (``cyborg doctor``);
- :mod:`~cyborg.transport.embedded`: the in-process graph (the default, also the test fake);
  :mod:`~cyborg.transport.ros` (ROS 1) and :mod:`~cyborg.transport.ros2` (ROS 2);
- :mod:`~cyborg.transport.guards`: what a subscriber believes of the graph (one sender only,
  texts within the API's limit);
- what they share: :mod:`~cyborg.transport._queue` (subscription queues),
  :mod:`~cyborg.transport._goals` (a client's goal handle), :mod:`~cyborg.transport._callbacks`
  (running a component's callback), :mod:`~cyborg.transport._host` and
  :mod:`~cyborg.transport._convert` (what the ROS transports share);
- :mod:`~cyborg.transport.watchdog`: notices a blocked event loop and names the callback that holds it.

:class:`EmbeddedTransport` is imported when first asked for, so that a process using only
the ROS transport (``cyborg.transport.ros``) does not load it.
"""

from typing import TYPE_CHECKING, Any

from cyborg.transport.base import (
    ActionClient,
    ActionServer,
    ClientGoalHandle,
    GoalStatus,
    MessageInfo,
    Node,
    Publisher,
    ServerGoalHandle,
    ServiceProxy,
    Subscription,
    Transport,
    TransportStats,
)
from cyborg.transport.clock import Clock, RealClock, VirtualClock

if TYPE_CHECKING:
    from cyborg.transport.embedded import EmbeddedTransport

__all__ = [
    "ActionClient",
    "ActionServer",
    "ClientGoalHandle",
    "Clock",
    "EmbeddedTransport",
    "GoalStatus",
    "MessageInfo",
    "Node",
    "Publisher",
    "RealClock",
    "ServerGoalHandle",
    "ServiceProxy",
    "Subscription",
    "Transport",
    "TransportStats",
    "VirtualClock",
]


def __getattr__(name: str) -> Any:
    if name == "EmbeddedTransport":
        from cyborg.transport.embedded import EmbeddedTransport

        return EmbeddedTransport
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
