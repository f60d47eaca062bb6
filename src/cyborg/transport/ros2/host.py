"""What the topics, services and actions of the ROS 2 transport need of the transport that made them.

Part of :mod:`cyborg.transport.ros2`. :class:`~.transport.Ros2Transport` satisfies :class:`Host`:
the shared :class:`cyborg.transport._host.Host`, and a way to wake its executor.
"""

from __future__ import annotations

from typing import Protocol

from cyborg.transport import _host

__all__ = ["Host"]


class Host(_host.Host, Protocol):
    def wake(self) -> None:
        """Wake the executor (something was made or finished from another thread)."""
