"""The executor that spins a Ros2Transport's nodes: rclpy's multi-threaded one, handing work over cleanly.

Part of :mod:`cyborg.transport.ros2`. Two habits of rclpy's ``MultiThreadedExecutor`` (Kilted)
made every hand-over between its thread and its pool slow under load (measured in the ROS 2
handover benchmark: events and action results reached the controller tens to hundreds of ms
late, now and then):

* Once it hands a ready subscription, client or action to a pool thread, it leaves that
  entity out of its wait set until the thread has taken the message. Yet until then every
  wait returned at once with nothing ready (seen: 1,100 empty waits in 150 ms; most likely the
  DDS reader's status condition, which the entity's QoS-event handlers keep in the wait set,
  stays triggered by the untaken message): the executor's thread spun, re-building its wait
  set in Python, and held the GIL the pool thread needed to take the message.
* It offers a task again at every turn until a pool thread has begun it, and queues it again
  each time (seen: 900 copies of one task, scanned at every turn).

:class:`HandOffExecutor` queues a task once, and after handing a ready entity to the pool
waits (the GIL released) until a pool thread has begun it before it waits for new work. A
subscription's message and an action client's answers are taken on the executor's own thread
instead (our callbacks for them only convert what came and hand it to the event loop): no pool
thread, no hand-over. rclpy's handler of such a message triggers the executor's guard condition
twice (the entity may be waited for again, its callback group is free), which made the next
wait return at once and the wait set be built twice per message, in Python; on the executor's
own thread those triggers are left out (:class:`_InlineGuard`): it builds the wait set anew
after the callback anyway. Nothing
is lost by waiting: the pool begins its tasks in order, so no later task could run sooner, and
our callbacks that hold a pool thread (an action server's goal decision and execution, a
service request) wait for the event loop, never for this executor. A shutdown ends the wait.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from rclpy.action import ActionClient
from rclpy.action import ActionServer as RclActionServer
from rclpy.context import Context
from rclpy.executors import (
    ConditionReachedException,
    ExternalShutdownException,
    MultiThreadedExecutor,
    ShutdownException,
    TimeoutException,
)
from rclpy.guard_condition import GuardCondition
from rclpy.subscription import Subscription
from rclpy.task import Task

__all__ = ["HandOffExecutor"]

SHUTDOWN_CHECK = 0.1  # seconds between looks at a shutdown while a hand-off is waited for

_QUICK = (Subscription, ActionClient)
"""Entities whose callbacks (ours) only take what came and hand it to the event loop."""


def _answers_only(entity: object) -> bool:
    """An action server whose ready work is only cancel or result requests (or goals to expire):
    our callbacks for those hand a cancel to the event loop and answer at once. A goal request
    waits for the module's decision on the event loop: the pool."""
    return isinstance(entity, RclActionServer) and not getattr(entity, "_is_goal_request_ready", True)


_IDLE = (ConditionReachedException, ExternalShutdownException, ShutdownException, TimeoutException)


class _InlineGuard(GuardCondition):  # type: ignore[misc]
    """The executor's guard condition, not triggered by a callback that runs on the executor's own
    thread (:attr:`muted_on`): its wake-up would only make the executor build the same wait set again."""

    def __init__(self, context: Context) -> None:
        super().__init__(callback=None, callback_group=None, context=context)
        self.muted_on: int | None = None

    def trigger(self) -> None:
        if self.muted_on != threading.get_ident():
            super().trigger()


class HandOffExecutor(MultiThreadedExecutor):  # type: ignore[misc]
    """A multi-threaded executor whose pool holds each task once, and that lets the pool take a
    ready entity's message before it waits again."""

    _guard: Any  # rclpy's: what wakes its wait (replaced by an _InlineGuard)

    def __init__(self, num_threads: int, *, context: Context) -> None:
        super().__init__(num_threads=num_threads, context=context)
        self._queued: set[Task[Any]] = set()  # handed to the pool, not begun yet
        self._entity_tasks = 0  # of those, the ones that take a ready entity's message
        self._begun = threading.Condition()
        self._guard.destroy()
        self._inline_guard = _InlineGuard(context)
        self._guard = self._inline_guard

    def _spin_once_impl(
        self, timeout_sec: float | None = None, wait_condition: Callable[[], bool] = lambda: False
    ) -> None:
        with self._begun:
            while self._entity_tasks and not self._is_shutdown and self._context.ok():
                self._begun.wait(SHUTDOWN_CHECK)
        try:
            task, entity, _ = self.wait_for_ready_callbacks(timeout_sec, None, wait_condition)
        except _IDLE:
            return
        if (isinstance(entity, _QUICK) or _answers_only(entity)) and not task.executing():
            # A message to a topic, or an action client's answer, feedback or result: taking it and
            # handing it to the event loop is quick, so it runs here; a thread of the pool would
            # cost two thread switches a message (most of the CPU of a node that hears 10 poses a
            # second); so are an action server's cancel and result requests. Its goal request and a
            # service's callback wait for the loop: the pool.
            self._inline_guard.muted_on = threading.get_ident()
            try:
                task()
            finally:
                self._inline_guard.muted_on = None
            if task.done():
                task.result()  # raise what the callback raised, as rclpy's executor does
            return
        with self._begun:
            if task in self._queued:
                return  # still waiting for a thread of the pool
            self._queued.add(task)
            takes = entity is not None and not task.executing()
            if takes:
                self._entity_tasks += 1
        self._executor.submit(self._run, task, takes)
        if task not in self._futures:
            self._futures.append(task)
        for future in self._futures[:]:
            if future.done():
                self._futures.remove(future)
                future.result()  # raise what the callback raised, as rclpy's executor does

    def _run(self, task: Task[Any], takes: bool) -> None:  # a thread of the pool
        with self._begun:
            self._queued.discard(task)
            if takes:
                self._entity_tasks -= 1
                self._begun.notify_all()
        # A coroutine task that awaits something is offered again once this step returns.
        task()
