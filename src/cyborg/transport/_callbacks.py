"""Running a component's callback on the loop, shared by every transport.

Every callback a component hands a transport (a subscription's, an action server's ``on_goal``,
a goal's ``on_status`` ...) runs through the transport's :class:`CallbackRunner`, on the clock's
event loop: a failure is logged and counted, never raised into the transport, and an awaitable
the callback returns runs as a task. Nothing here knows of ROS.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
from collections.abc import Callable
from typing import Any

__all__ = ["CallbackRunner"]


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
        """Call ``callback(*args)`` now (on the loop); start the awaitable it returns as a task."""
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
