"""The client's side of one action goal, shared by every transport.

:class:`ClientGoal` is what :meth:`ActionClient.send_goal` returns: it holds the goal's status,
result and text, runs the sender's ``on_status`` and ``on_feedback`` callbacks, wakes
:meth:`~ClientGoal.wait` and runs the done callbacks once the goal is finished. A transport
subclasses it to say how a cancel reaches the server, and feeds it what the server reports with
:meth:`~ClientGoal.update_status` and :meth:`~ClientGoal.deliver_feedback`, always on the clock's
event loop. Nothing here knows of ROS: the embedded, ROS 1 and ROS 2 transports use it alike.
"""

from __future__ import annotations

import asyncio
from abc import abstractmethod
from collections.abc import Awaitable, Callable

from cyborg.transport.base import ClientGoalHandle, F, G, GoalStatus, R
from cyborg.transport.clock import Clock

__all__ = ["ClientGoal"]


class ClientGoal(ClientGoalHandle[G, R, F]):
    """One goal as its client sees it: PENDING until the server reports otherwise.

    A status reported twice is taken once; after a terminal status (which carries the result and
    its text) nothing changes any more. Callbacks run through ``run`` (the transport's
    :class:`~cyborg.transport._callbacks.CallbackRunner`), so a failing one does not stop the others.
    """

    def __init__(
        self,
        goal: G,
        *,
        clock: Clock,
        run: Callable[..., None],
        on_feedback: Callable[[F], Awaitable[None] | None] | None,
        on_status: Callable[[GoalStatus], Awaitable[None] | None] | None,
    ) -> None:
        self.goal = goal
        self._clock = clock
        self._run = run
        self._on_feedback = on_feedback
        self._on_status = on_status
        self._status = GoalStatus.PENDING
        self._result: R | None = None
        self._text = ""
        self._done: list[Callable[[ClientGoalHandle[G, R, F]], None]] = []
        self._waiters: list[asyncio.Future[GoalStatus]] = []

    @property
    def status(self) -> GoalStatus:
        return self._status

    @property
    def result(self) -> R | None:
        return self._result

    @property
    def text(self) -> str:
        return self._text

    def cancel(self) -> None:
        if not self._status.is_terminal:
            self._request_cancel()

    @abstractmethod
    def _request_cancel(self) -> None:
        """Ask the server to cancel this goal (it is not finished yet)."""

    def _finished(self) -> None:
        """Called once, when the goal reaches a terminal status (before waiters wake)."""

    async def wait(self) -> GoalStatus:
        if self._status.is_terminal:
            return self._status
        future: asyncio.Future[GoalStatus] = self._clock.loop.create_future()
        self._waiters.append(future)
        return await future

    def add_done_callback(self, callback: Callable[[ClientGoalHandle[G, R, F]], None]) -> None:
        if self._status.is_terminal:
            self._clock.loop.call_soon(callback, self)
        else:
            self._done.append(callback)

    # what the server reports, on the loop
    def update_status(self, status: GoalStatus, result: R | None, text: str) -> None:
        """Take the status the server reported; a repeated one, or any after a terminal one, is ignored."""
        if self._status.is_terminal or status is self._status:
            return
        self._status = status
        if status.is_terminal:
            self._result, self._text = result, text
        if self._on_status is not None:
            self._run(self._on_status, status)
        if not status.is_terminal:
            return
        self._finished()
        for waiter in self._waiters:
            if not waiter.done():
                waiter.set_result(status)
        self._waiters.clear()
        callbacks, self._done = self._done, []
        for callback in callbacks:
            self._run(callback, self)

    def deliver_feedback(self, feedback: F) -> None:
        """Hand the server's feedback to ``on_feedback``, until the goal is finished."""
        if self._on_feedback is not None and not self._status.is_terminal:
            self._run(self._on_feedback, feedback)
