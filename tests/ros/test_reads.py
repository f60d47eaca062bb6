"""Subscriptions read on the event loop (:mod:`cyborg.transport.ros.reads`), on a real roscore.

Our components' connections are read by the loop; a plain rospy subscriber that shares a topic
with them in the same process is still served by rospy's thread: its callback may block (rospy
allows it) without stopping the loop, and both see every message in order.
"""

from __future__ import annotations

import asyncio
import itertools
import threading
import time
from typing import Any

import pytest

from cyborg.transport.base import MessageInfo
from cyborg.transport.messages import String
from tests.support.ros import RosSession

pytestmark = pytest.mark.ros

_names = itertools.count(1)
PATIENCE = 10.0  # real seconds a wait may take before the test fails


async def _until(found: Any, what: str) -> None:
    deadline = time.monotonic() + PATIENCE
    while not found():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        await asyncio.sleep(0.01)


def test_a_plain_rospy_subscriber_beside_ours_blocks_only_itself_and_both_get_every_message(
    ros: RosSession,
) -> None:
    import rospy  # type: ignore[import-not-found]
    from std_msgs.msg import String as RosString  # type: ignore[import-not-found]

    number = next(_names)
    topic = f"/reads_test{number}/chatter"
    node = ros.transport.node(f"reads_test{number}")
    ours: list[tuple[str, int]] = []
    plain: list[str] = []
    release = threading.Event()
    released: list[bool] = []

    def on_ours(message: String, info: MessageInfo) -> None:
        ours.append((message.data, threading.get_ident()))

    def on_plain(message: Any) -> None:  # rospy's thread; the first message blocks it until the loop says
        plain.append(str(message.data))
        if len(plain) == 1:
            released.append(release.wait(PATIENCE))

    async def main() -> int:
        loop_thread = threading.get_ident()
        publisher = node.publisher(topic, String)  # first: rospy connects the subscriber at once
        subscription = node.subscribe(topic, String, on_ours)
        await _until(lambda: publisher.subscriber_count() >= 1, "our subscriber's connection")
        for i in range(3):
            publisher.publish(String(f"a{i}"))
        await _until(lambda: len(ours) == 3, "our first three messages")
        plain_sub = rospy.Subscriber(topic, RosString, on_plain)
        try:
            await _until(lambda: plain_sub.get_num_connections() >= 1, "the plain subscriber's connection")
            for i in range(3):
                publisher.publish(String(f"b{i}"))
            # The plain callback blocks on the first of them until this loop's timer releases it:
            # had it run on the loop, the timer could not fire before its wait ran out.
            asyncio.get_running_loop().call_later(0.1, release.set)
            await _until(
                lambda: len(ours) == 6 and len(plain) == 3, "the next three, ours and the plain one's"
            )
        finally:
            release.set()
            plain_sub.unregister()
            subscription.unsubscribe()
        return loop_thread

    loop_thread = ros.clock.run(main())
    assert [data for data, _ in ours] == ["a0", "a1", "a2", "b0", "b1", "b2"]
    assert plain == ["b0", "b1", "b2"]
    assert {thread for _, thread in ours} == {loop_thread}
    assert released == [True], "a plain rospy callback ran on the loop and held it up"


def test_a_latched_message_reaches_a_later_subscription_with_nothing_published_after_it(
    ros: RosSession,
) -> None:
    number = next(_names)
    topic = f"/reads_test{number}/latched"
    node = ros.transport.node(f"reads_test{number}")
    got: list[str] = []

    async def main() -> None:
        publisher = node.publisher(topic, String, latch=True)
        publisher.publish(String("kept"))
        # rospy sends the kept message right after the connection's header: it may be read with it
        subscription = node.subscribe(topic, String, lambda message, info: got.append(message.data))
        try:
            await _until(lambda: got == ["kept"], "the latched message")
        finally:
            subscription.unsubscribe()

    ros.clock.run(main())


def test_an_action_server_still_counts_as_there_right_after_the_loop_was_busy_a_while(
    ros: RosSession,
) -> None:
    """Its status messages wait unread while the loop is busy; a goal sent right after must not
    end LOST because the server looked silent (rospy's threads used to read them meanwhile)."""
    from cyborg.transport.base import GoalStatus, ServerGoalHandle
    from cyborg.transport.messages import StateMachineAction, StateMachineGoal

    number = next(_names)
    action = f"/reads_test{number}/act"
    node = ros.transport.node(f"reads_test{number}")

    def on_goal(handle: ServerGoalHandle[Any, Any, Any]) -> None:
        handle.accept()

    async def main() -> GoalStatus:
        server = node.action_server(action, StateMachineAction, on_goal, lambda handle: handle.canceled())
        client = node.action_client(action, StateMachineAction)
        try:
            assert await client.wait_for_server(PATIENCE)
            time.sleep(1.5)  # the loop is busy (a module's slow callback): longer than the silence limit
            goal = client.send_goal(StateMachineGoal(event="go"))
            await _until(lambda: goal.status is not GoalStatus.PENDING, "the goal's answer")
            status = goal.status
            goal.cancel()
            await asyncio.wait_for(goal.wait(), PATIENCE)
            return status
        finally:
            server.shutdown()

    assert ros.clock.run(main()) is GoalStatus.ACTIVE
