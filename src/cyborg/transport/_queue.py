"""The bounded subscription queue, shared by every transport.

A transport hands each received message to :class:`SubscriptionQueue` on the clock's event
loop (the embedded transport directly, ROS from its receiving threads through
``call_soon_threadsafe``). The queue holds at most ``queue_size`` messages: when full, the
oldest is dropped and counted. It is drained on a later loop turn, each message given to the
subscriber's callback through the transport's
:class:`~cyborg.transport._callbacks.CallbackRunner`, so one failing callback never stops
delivery. Nothing here knows of ROS: the embedded, ROS 1 and ROS 2 transports use it alike.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Awaitable, Callable
from typing import Generic

from cyborg.errors import TransportError
from cyborg.transport.base import M, MessageInfo, TransportStats
from cyborg.transport.clock import Clock

__all__ = ["SubscriptionQueue", "check_queue_size"]


def check_queue_size(queue_size: int) -> None:
    """A subscription's queue holds at least one message."""
    if queue_size < 1:
        raise TransportError(f"queue_size must be at least 1, got {queue_size}")


class SubscriptionQueue(Generic[M]):
    """A subscription's bounded queue of received messages, drained on the loop into its callback.

    :meth:`put` (on the loop) appends a message; when ``queue_size`` messages wait already, the
    oldest is dropped and counted, in :attr:`dropped` and in the transport's ``stats``. The first message
    of a batch schedules a drain on the next loop turn, which hands every waiting message, in
    order, to ``callback`` through ``run``. After :meth:`close` nothing more is delivered.
    """

    def __init__(
        self,
        clock: Clock,
        callback: Callable[[M, MessageInfo], Awaitable[None] | None],
        queue_size: int,
        run: Callable[..., None],
        stats: TransportStats,
    ) -> None:
        check_queue_size(queue_size)
        self._clock = clock
        self._callback = callback
        self._queue_size = queue_size
        self._run = run
        self._stats = stats
        self._queue: deque[tuple[M, MessageInfo]] = deque()
        self._scheduled = False
        self._active = True
        self.dropped = 0

    def put(self, message: M, info: MessageInfo) -> None:
        """Queue ``message`` for the callback (on the loop); nothing after :meth:`close`."""
        if not self._active:
            return
        if len(self._queue) >= self._queue_size:
            self._queue.popleft()
            self.dropped += 1
            self._stats.dropped_messages += 1
        self._queue.append((message, info))
        if not self._scheduled:
            self._scheduled = True
            self._clock.loop.call_soon(self._drain)

    def _drain(self) -> None:
        self._scheduled = False
        queue = self._queue
        while queue and self._active:
            message, info = queue.popleft()
            self._run(self._callback, message, info)

    def close(self) -> None:
        """Deliver nothing more: what waits is discarded, and what arrives later too."""
        self._active = False
        self._queue.clear()
