"""What an action client counts for lockstep time, against a plain actionlib server on a real roscore.

Lockstep time (:mod:`cyborg.run.lockstep`) holds the virtual time while a goal's first answer is
on its way: the server counts it sent when it accepts, the client received when it sees it. A
client that misses it holds the time until the server's patience writes it off (scenario B over
ROS 1 once stopped 2 s that way, and the run was no longer exact).
"""

from __future__ import annotations

import asyncio
import itertools
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import pytest

from cyborg.transport.base import GoalStatus
from cyborg.transport.ledger import Ledger
from cyborg.transport.messages import StateMachineAction, StateMachineGoal
from tests.support.ros import RosSession

pytestmark = pytest.mark.ros

_names = itertools.count(1)
PATIENCE = 10.0  # real seconds a wait may take before the test fails


def test_a_goal_cancelled_before_its_acceptance_arrived_still_counts_the_acceptance(
    ros: RosSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The controller preempts a state in the instant it entered it: actionlib's client, waiting
    for the cancel's answer, ignores the ACTIVE status; the first answer it sees is PREEMPTING,
    and the module may take a while (virtual time) to finish. The acceptance must count then."""
    import actionlib  # type: ignore[import-not-found]
    from cyborg_controller.msg import StateMachineAction as RosAction  # type: ignore[import-not-found]

    number = next(_names)
    action = f"/counts_test{number}/act"
    accepted = threading.Event()
    cancelled = threading.Event()
    held: list[Any] = []

    def on_goal(handle: Any) -> None:  # rospy thread
        handle.set_accepted()
        held.append(handle)
        accepted.set()

    def on_cancel(handle: Any) -> None:  # rospy thread: the module takes its time to stop
        cancelled.set()

    server = actionlib.ActionServer(action, RosAction, on_goal, on_cancel, auto_start=False)
    server.start()

    ledger = Ledger()
    monkeypatch.setattr(ros.clock, "ledger", ledger, raising=False)
    arrive = ros.transport.arrive

    def counting_arrive(
        channel: str, sender: str, callback: Callable[..., object], *args: Any, counted: Sequence[str] = ()
    ) -> None:  # what a lockstep clock does with ``counted``
        for leg in counted:
            ledger.received(leg)
        arrive(channel, sender, callback, *args, counted=counted)

    monkeypatch.setattr(ros.transport, "arrive", counting_arrive)
    node = ros.transport.node(f"counts_test{number}")

    totals: dict[str, int] = {}

    def received(leg: str) -> int:
        changes = ledger.take_changes() or {}
        for channel, count in changes.get("recv", {}).items():
            totals[channel] = totals.get(channel, 0) + count
        return totals.get(f"{action}#{leg}", 0)

    async def main() -> GoalStatus:
        client = node.action_client(action, StateMachineAction)
        assert await client.wait_for_server(PATIENCE), "the plain server was not found"
        goal = client.send_goal(StateMachineGoal(event="go"))
        # The loop reads the client's status messages: until it turns, the ACTIVE one waits unread.
        assert accepted.wait(PATIENCE), "the server never got the goal"
        goal.cancel()
        assert cancelled.wait(PATIENCE), "the server never got the cancel"
        deadline = time.monotonic() + PATIENCE
        while received("accept") == 0 and time.monotonic() < deadline:
            await asyncio.sleep(0.01)
        seen = goal.status
        assert received("accept") == 1, f"the acceptance was not counted (the goal is {seen.name})"
        assert received("result") == 0, "nothing has ended yet"
        held[0].set_canceled()
        status = await asyncio.wait_for(goal.wait(), PATIENCE)
        assert (received("accept"), received("result")) == (1, 1), "each answer counts once"
        return status

    try:
        assert ros.clock.run(main()) is GoalStatus.PREEMPTED
    finally:
        for attribute in ("goal_sub", "cancel_sub", "status_pub", "result_pub", "feedback_pub"):
            getattr(server, attribute).unregister()
        server.status_timer.shutdown()
