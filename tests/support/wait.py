"""Waiting in real time for another process (a master's answer, a log line, a file)."""

from __future__ import annotations

import time
from collections.abc import Callable


def wait_for(condition: Callable[[], object], *, timeout: float, what: str, interval: float = 0.02) -> None:
    """Poll ``condition`` until it holds; fails the test after ``timeout`` real seconds.

    In virtual time, or on a clock of the robot's, use :func:`cyborg.testing.wait_until`."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"not within {timeout} s: {what}")
        time.sleep(interval)
