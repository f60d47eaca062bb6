"""The pieces every transport shares (cyborg.transport._queue, _callbacks, _goals), on their own,
and the ROS 1 transport's import: it patches nothing and loads only what the transport needs."""

from __future__ import annotations

import json
import logging
import subprocess
import sys
from typing import Any

import pytest

from cyborg.errors import TransportError
from cyborg.transport._callbacks import CallbackRunner
from cyborg.transport._goals import ClientGoal
from cyborg.transport._queue import SubscriptionQueue
from cyborg.transport.base import GoalStatus, MessageInfo, TransportStats
from cyborg.transport.clock import VirtualClock
from cyborg.transport.messages import StateMachineFeedback, StateMachineGoal, StateMachineResult, String

log = logging.getLogger(__name__)
INFO = MessageInfo(sender="talker", stamp=0.0)


class Errors:
    def __init__(self) -> None:
        self.count = 0

    def __call__(self) -> None:
        self.count += 1


def test_queue_delivers_on_a_later_turn_and_drops_the_oldest(clock: VirtualClock) -> None:
    got: list[str] = []
    stats = TransportStats()
    queue: SubscriptionQueue[String] = SubscriptionQueue(
        clock, lambda m, i: got.append(m.data), 3, CallbackRunner(log, Errors()), stats
    )

    async def main() -> None:
        for n in range(5):
            queue.put(String(str(n)), INFO)
        assert got == []  # never synchronously
        await clock.sleep(0)

    clock.run(main())
    assert got == ["2", "3", "4"]
    assert queue.dropped == 2 and stats.dropped_messages == 2


def test_a_failing_callback_is_counted_and_delivery_goes_on(clock: VirtualClock) -> None:
    got: list[str] = []
    errors = Errors()

    def callback(message: String, info: MessageInfo) -> None:
        if message.data == "bad":
            raise RuntimeError("boom")
        got.append(message.data)

    async def failing_task(message: String, info: MessageInfo) -> None:
        raise RuntimeError("boom later")

    runner = CallbackRunner(log, errors)
    queue: SubscriptionQueue[String] = SubscriptionQueue(clock, callback, 10, runner, TransportStats())
    later: SubscriptionQueue[String] = SubscriptionQueue(clock, failing_task, 10, runner, TransportStats())

    async def main() -> None:
        for data in ("a", "bad", "b"):
            queue.put(String(data), INFO)
        later.put(String("x"), INFO)
        await clock.sleep(0.1)

    clock.run(main())
    assert got == ["a", "b"]
    assert errors.count == 2  # the raising callback and the failed task


def test_a_closed_queue_delivers_nothing_more(clock: VirtualClock) -> None:
    got: list[str] = []
    queue: SubscriptionQueue[String] = SubscriptionQueue(
        clock, lambda m, i: got.append(m.data), 10, CallbackRunner(log, Errors()), TransportStats()
    )

    async def main() -> None:
        queue.put(String("waiting"), INFO)
        queue.close()
        queue.put(String("in flight"), INFO)
        await clock.sleep(0.1)

    clock.run(main())
    assert got == []


def test_a_queue_holds_at_least_one_message(clock: VirtualClock) -> None:
    with pytest.raises(TransportError, match="queue_size must be at least 1"):
        SubscriptionQueue(clock, lambda m, i: None, 0, CallbackRunner(log, Errors()), TransportStats())


class _Goal(ClientGoal[StateMachineGoal, StateMachineResult, StateMachineFeedback]):
    def __init__(self, clock: VirtualClock, **callbacks: Any) -> None:
        super().__init__(StateMachineGoal(), clock=clock, run=CallbackRunner(log, Errors()), **callbacks)
        self.cancels = 0
        self.finished = 0

    def _request_cancel(self) -> None:
        self.cancels += 1

    def _finished(self) -> None:
        self.finished += 1


def test_client_goal_reports_each_status_once_and_finishes_once(clock: VirtualClock) -> None:
    statuses: list[tuple[GoalStatus, StateMachineResult | None]] = []
    feedback: list[StateMachineFeedback] = []
    goal: _Goal

    def on_status(status: GoalStatus) -> None:
        statuses.append((status, goal.result))  # a terminal status comes with its result

    goal = _Goal(clock, on_status=on_status, on_feedback=feedback.append)
    done: list[GoalStatus] = []
    goal.add_done_callback(lambda handle: done.append(handle.status))
    result = StateMachineResult()

    async def main() -> GoalStatus:
        waiting = clock.loop.create_task(goal.wait())
        goal.update_status(GoalStatus.ACTIVE, None, "")
        goal.update_status(GoalStatus.ACTIVE, None, "")
        goal.deliver_feedback(StateMachineFeedback())
        goal.cancel()
        goal.update_status(GoalStatus.PREEMPTED, result, "stopped")
        goal.update_status(GoalStatus.SUCCEEDED, None, "too late")
        goal.deliver_feedback(StateMachineFeedback())
        goal.cancel()
        return await waiting

    assert clock.run(main()) is GoalStatus.PREEMPTED
    assert statuses == [(GoalStatus.ACTIVE, None), (GoalStatus.PREEMPTED, result)]
    assert len(feedback) == 1 and done == [GoalStatus.PREEMPTED]
    assert goal.result is result and goal.text == "stopped"
    assert goal.cancels == 1 and goal.finished == 1

    late: list[GoalStatus] = []
    goal.add_done_callback(lambda handle: late.append(handle.status))
    assert late == []  # on a later loop turn, even when already finished
    clock.run(clock.sleep(0))
    assert late == [GoalStatus.PREEMPTED]


def test_importing_the_ros_transport_patches_nothing_and_loads_only_what_it_needs() -> None:
    script = """
import json, sys
import rospy
import cyborg.transport.ros
from cyborg.transport.ros import patches
from rospy.impl.registration import RegManager
before = [getattr(rospy.topics.Subscriber.__init__, "_cyborg_nodelay", False),
          getattr(RegManager.reg_added, "_cyborg_once", False)]
patches.install()
patches.install()
after = [getattr(rospy.topics.Subscriber.__init__, "_cyborg_nodelay", False),
         getattr(RegManager.reg_added, "_cyborg_once", False)]
heavy = sorted(m for m in ("pydantic", "scipy", "aiohttp", "cyborg.transport.embedded") if m in sys.modules)
print(json.dumps({"before": before, "after": after, "heavy": heavy}))
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    found = json.loads(out.stdout.strip().splitlines()[-1])
    assert found == {"before": [False, False], "after": [True, True], "heavy": []}
