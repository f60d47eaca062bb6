"""What the topics, services and actions of a ROS transport need of the transport that made them.

rospy and rclpy call back on threads of their own; the parts of :mod:`cyborg.transport.ros`
and :mod:`cyborg.transport.ros2` hand each callback to the clock's loop through their
:class:`Host`, which both transports satisfy with :class:`~cyborg.transport.base.Transport`'s
members. Naming the protocol below the transports keeps their packages free of import cycles.
Both wait for a server or service the same way: :func:`poll_until`, on the injected clock.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

from cyborg.transport.base import TransportStats
from cyborg.transport.clock import Clock

__all__ = ["LOCKSTEP_FIND_LIMIT", "POLL_PERIOD", "Host", "poll_real", "poll_until"]

POLL_PERIOD = 0.01  # clock seconds between two looks for a server
# Lockstep: the fewest real seconds a wait for a server lasts (the time is held meanwhile). What
# a wait finds must not depend on how loaded the machine is: a module of the launch found after
# 2 real s at load 39 ended its state as aborted, and the run differed from the one in process.
# A server that is really missing costs this much real time, and no more virtual time than before.
LOCKSTEP_FIND_LIMIT = 20.0


class Host(Protocol):
    """The transport, as its topics, services and actions see it."""

    clock: Clock

    @property
    def stats(self) -> TransportStats:
        """The transport's counters: a publisher counts what it sends, a queue what it drops."""

    def to_loop(self, callback: Callable[..., object], *args: Any) -> None:
        """Run ``callback(*args)`` on the clock's loop; called from the middleware's threads."""

    def arrive(
        self,
        channel: str,
        sender: str,
        callback: Callable[..., object],
        *args: Any,
        counted: Sequence[str] = (),
    ) -> None:
        """A message arrived: ``to_loop``, or with lockstep time in the next delta cycle."""

    def run_callback(self, callback: Callable[..., object], *args: Any) -> None:
        """Run a component's callback now, on the loop, counting and logging its failure."""


async def poll_until(found: Callable[[], bool], clock: Clock, timeout: float) -> bool:
    """Call ``found()`` every POLL_PERIOD until it is true (True) or ``timeout`` clock seconds pass (False).

    With lockstep time, what is looked for (a server found by the middleware) comes in real
    time: the time is held meanwhile and the wait lasts ``timeout`` real seconds, at least
    LOCKSTEP_FIND_LIMIT, so that it costs no virtual time and a run repeats exactly.
    """
    if clock.is_lockstep:
        return await poll_real(found, clock, max(timeout, LOCKSTEP_FIND_LIMIT))
    deadline = clock.monotonic() + timeout
    while not found():
        if clock.monotonic() >= deadline:
            return False
        await clock.sleep(POLL_PERIOD)
    return True


async def poll_real(found: Callable[[], bool], clock: Clock, timeout: float) -> bool:
    """Call ``found()`` every POLL_PERIOD real seconds until it is true or ``timeout`` real seconds
    pass; a lockstep clock's time is held meanwhile (:meth:`LockstepClock.hold`)."""
    if found():
        return True
    with clock.hold():
        loop = asyncio.get_running_loop()
        deadline = time.monotonic() + timeout
        while not found():
            if time.monotonic() >= deadline:
                return False
            await loop.run_in_executor(None, time.sleep, POLL_PERIOD)
    return True
