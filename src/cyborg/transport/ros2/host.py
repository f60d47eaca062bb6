"""What the topics, services and actions of the ROS 2 transport need of the transport that made them.

Part of :mod:`cyborg.transport.ros2`. :class:`~.transport.Ros2Transport` satisfies :class:`Host`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from cyborg.transport.clock import Clock

__all__ = ["Host"]


class Host(Protocol):
    clock: Clock

    def to_loop(self, callback: Callable[..., object], *args: Any) -> None:
        """Run ``callback(*args)`` on the clock's loop; called from the executor's threads."""

    def run_callback(self, callback: Callable[..., object], *args: Any) -> None:
        """Run a component's callback now, on the loop, counting and logging its failure."""

    def wake(self) -> None:
        """Wake the executor (something was made or finished from another thread)."""
