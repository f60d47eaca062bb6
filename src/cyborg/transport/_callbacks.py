"""Running a component's callback on the loop, shared by every transport.

Every callback a component hands a transport (a subscription's, an action server's ``on_goal``,
a goal's ``on_status`` ...) runs through the transport's :class:`CallbackRunner`, on the clock's
event loop: a failure is logged and counted, never raised into the transport, and an awaitable
the callback returns runs as a task. A callback that fails again and again (on every sentence
heard, say) gets its traceback once, then one line at most every ``REPEAT_PERIOD`` seconds
with the count. Nothing here knows of ROS.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
import time
from collections.abc import Callable
from typing import Any

__all__ = ["CallbackRunner"]


REPEAT_PERIOD = 10.0
"""Real seconds between two lines about a callback that keeps failing (the log's size is a real cost)."""


def _describe(callback: Callable[..., object]) -> str:
    return getattr(callback, "__qualname__", repr(callback))


class CallbackRunner:
    """Runs a component's callback on the loop, never letting its failure reach the transport.

    A callback that raises is logged (on ``log``) and counted by ``on_error``; one that returns an
    awaitable has it run as a task, kept until it is done, whose failure is logged and counted too.
    """

    def __init__(
        self, log: logging.Logger, on_error: Callable[[], None], *, now: Callable[[], float] = time.monotonic
    ) -> None:
        self._log = log
        self._on_error = on_error
        self._now = now
        self._tasks: set[asyncio.Future[Any]] = set()
        self._failing: dict[str, tuple[float, int]] = {}  # callback -> (when last logged, failures since)

    def __call__(self, callback: Callable[..., object], *args: Any) -> None:
        """Call ``callback(*args)`` now (on the loop); start the awaitable it returns as a task."""
        try:
            result = callback(*args)
            if result is not None and inspect.isawaitable(result):  # most callbacks return None
                task = asyncio.ensure_future(result)
                self._tasks.add(task)
                task.add_done_callback(self._task_done)
        except Exception as exc:
            self._on_error()
            self._failed(_describe(callback), exc)

    def _failed(self, name: str, exc: Exception) -> None:
        now = self._now()
        seen = self._failing.get(name)
        if seen is None:
            self._failing[name] = (now, 0)
            self._log.error("callback %s failed; the transport carries on", name, exc_info=exc)
            return
        logged, since = seen
        if now - logged < REPEAT_PERIOD:
            self._failing[name] = (logged, since + 1)
            return
        self._failing[name] = (now, 0)
        self._log.error(
            "callback %s failed again (%d times in the last %.0f s, the traceback as the first time); latest: %s: %s",
            name,
            since + 1,
            now - logged,
            type(exc).__name__,
            exc,
        )

    def _task_done(self, task: asyncio.Future[Any]) -> None:
        self._tasks.discard(task)
        if not task.cancelled() and task.exception() is not None:
            self._on_error()
            self._log.error("callback task failed; the transport carries on", exc_info=task.exception())
