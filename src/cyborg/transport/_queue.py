"""Callback dispatch and the bounded subscription queue, shared by every transport.

A transport hands each received message to :class:`SubscriptionQueue` on the clock's event
loop (the embedded transport directly, ROS from its receiving threads through
``call_soon_threadsafe``). The queue holds at most ``queue_size`` messages: when full, the
oldest is dropped and counted. It is drained on a later loop turn, each message given to the
subscriber's callback through a :class:`CallbackRunner`, so one failing callback never stops
delivery. Nothing here knows of ROS: the embedded, ROS 1 and ROS 2 transports use it alike.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
from collections import deque
from collections.abc import Callable
from typing import Any, Generic

from cyborg.errors import TransportError
from cyborg.transport.base import M, MessageInfo
from cyborg.transport.clock import Clock

__all__ = ["CallbackRunner", "SubscriptionQueue", "check_queue_size"]


def check_queue_size(queue_size: int) -> None:
    """A subscription's queue holds at least one message."""
    if queue_size < 1:
        raise TransportError(f"queue_size must be at least 1, got {queue_size}")


def _describe(callback: Callable[..., object]) -> str:
    return getattr(callback, "__qualname__", repr(callback))


class CallbackRunner:
    """Runs a component's callback on the loop, never letting its failure reach the transport.

    A callback that raises is logged (on ``log``) and counted by ``on_error``; one that returns an
    awaitable has it run as a task, kept until it is done, whose failure is logged and counted too.
    """

    def __init__(self, log: logging.Logger, on_error: Callable[[], None]) -> None:
        self._log = log
        self._on_error = on_error
        self._tasks: set[asyncio.Future[Any]] = set()

    def __call__(self, callback: Callable[..., object], *args: Any) -> None:
        try:
            result = callback(*args)
            if result is not None and inspect.isawaitable(result):  # most callbacks return None
                task = asyncio.ensure_future(result)
                self._tasks.add(task)
                task.add_done_callback(self._task_done)
        except Exception:
            self._on_error()
            self._log.exception("callback %s failed; the transport carries on", _describe(callback))

    def _task_done(self, task: asyncio.Future[Any]) -> None:
        self._tasks.discard(task)
        if not task.cancelled() and task.exception() is not None:
            self._on_error()
            self._log.error("callback task failed; the transport carries on", exc_info=task.exception())


class SubscriptionQueue(Generic[M]):
    """A subscription's bounded queue of received messages, drained on the loop into its callback.

    :meth:`put` (on the loop) appends a message; when ``queue_size`` messages wait already, the
    oldest is dropped, counted in :attr:`dropped` and reported to ``on_drop``. The first message
    of a batch schedules a drain on the next loop turn, which hands every waiting message, in
    order, to ``callback`` through ``run``. After :meth:`close` nothing more is delivered.
    """

    def __init__(
        self,
        clock: Clock,
        callback: Callable[[M, MessageInfo], None],
        queue_size: int,
        run: Callable[..., None],
        on_drop: Callable[[], None] | None = None,
    ) -> None:
        check_queue_size(queue_size)
        self._clock = clock
        self._callback = callback
        self._queue_size = queue_size
        self._run = run
        self._on_drop = on_drop
        self._queue: deque[tuple[M, MessageInfo]] = deque()
        self._scheduled = False
        self._active = True
        self.dropped = 0

    def put(self, message: M, info: MessageInfo) -> None:
        if not self._active:
            return
        if len(self._queue) >= self._queue_size:
            self._queue.popleft()
            self.dropped += 1
            if self._on_drop is not None:
                self._on_drop()
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
