"""Transport layer: the interface components are written against, its in-process
implementation, the message types and the injected clock.

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
