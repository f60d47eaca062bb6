"""Transport layer: the interface components are written against, its in-process
implementation, the message types and the injected clock."""

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
)
from cyborg.transport.clock import Clock, RealClock, VirtualClock
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
    "VirtualClock",
]
