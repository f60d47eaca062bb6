"""The fixtures of the ROS 1 tests: the session's roscore, `cyborg node` processes, observers.

What they hand out is in tests/support/ros.py.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support.ros import Observers, Processes, RosSession, ros_session


@pytest.fixture(scope="session")
def ros(pytestconfig: pytest.Config) -> RosSession:
    return ros_session(pytestconfig)


@pytest.fixture
def processes(ros: RosSession, tmp_path: Path) -> Iterator[Processes]:
    procs = Processes(tmp_path)
    try:
        yield procs
    finally:
        procs.stop_all()


@pytest.fixture
def observe(ros: RosSession) -> Iterator[Observers]:
    observers = Observers()
    try:
        yield observers
    finally:
        observers.close()
