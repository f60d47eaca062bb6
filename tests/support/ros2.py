"""The ROS 2 session of a test process in .venv-ros2: one Ros2Transport on a real clock.

Used by tests/transport/test_contract.py (its ``ros2`` graph) and the tests under
tests/ros2. The process runs on a ROS_DOMAIN_ID of its own with discovery kept on this host
(tests/ros2/conftest.py and the runner in the ROS 1 venv set both before rclpy starts).
"""

from __future__ import annotations

import os
import random
import threading

import pytest

from cyborg.transport.clock import RealClock

_SESSION_ATTRIBUTE = "_cyborg_ros2_session"


def isolate() -> None:
    """Keep discovery on this host and pick a domain of this process's own (unless set already)."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(1, 100)))


class Ros2Session:
    def __init__(self) -> None:
        isolate()
        from cyborg.transport.ros2 import Ros2Transport

        self.clock = RealClock()
        self.transport = Ros2Transport(self.clock)
        self._lock = threading.Lock()

    def close(self) -> None:
        self.transport.close()
        self.clock.close()


def ros2_session(config: pytest.Config) -> Ros2Session:
    """The session's :class:`Ros2Session`, started on first use, closed when pytest ends."""
    session: Ros2Session | None = getattr(config, _SESSION_ATTRIBUTE, None)
    if session is None:
        session = Ros2Session()
        setattr(config, _SESSION_ATTRIBUTE, session)
        config.add_cleanup(session.close)
    return session
