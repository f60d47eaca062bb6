"""Waiting on a clock until something holds: for tests, benchmarks and tools that drive a robot."""

from __future__ import annotations

from collections.abc import Callable

from cyborg.transport.clock import Clock

__all__ = ["wait_until"]


async def wait_until(
    predicate: Callable[[], bool], clock: Clock, *, timeout: float, interval: float = 0.01
) -> bool:
    """Wait (on ``clock``) until ``predicate()`` is true; False on timeout."""
    deadline = clock.monotonic() + timeout
    while not predicate():
        if clock.monotonic() >= deadline:
            return False
        await clock.sleep(interval)
    return True
