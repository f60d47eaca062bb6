"""A result the middleware could not send reaches its client anyway (ROS 2 only).

Fast DDS refuses a service response when it has not matched the client's reader within 100 ms,
which happened on a loaded machine: rclpy dropped the result and the controller waited for a
module's result until it gave up on it. Our servers try again a little later.
"""

from __future__ import annotations

import asyncio

import pytest
from rclpy.action.server import RCLError

from cyborg.transport.base import GoalStatus, ServerGoalHandle
from cyborg.transport.messages import (
    StateMachineAction,
    StateMachineFeedback,
    StateMachineGoal,
    StateMachineResult,
)
from cyborg.transport.ros2 import actions
from tests.support.ros2 import ros2_session

Handle = ServerGoalHandle[StateMachineGoal, StateMachineResult, StateMachineFeedback]


def test_a_result_the_middleware_refused_is_sent_again(
    request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch
) -> None:
    session = ros2_session(request.config)
    refused: list[int] = []
    send = actions._RclServer._send_result_now

    def refuse_twice(self: actions._RclServer, header: object, result: object) -> None:
        if len(refused) < 2:
            refused.append(1)
            raise RCLError("client will not receive response")
        send(self, header, result)

    monkeypatch.setattr(actions._RclServer, "_send_result_now", refuse_twice)
    module, controller = session.transport.node("resend_module"), session.transport.node("resend_ctl")
    try:

        def on_goal(handle: Handle) -> None:
            handle.accept()
            session.clock.call_later(0.2, handle.succeed, StateMachineResult("done", "ok"))

        module.action_server("/resend/act", StateMachineAction, on_goal, lambda h: h.canceled())
        client = controller.action_client("/resend/act", StateMachineAction)

        async def trip() -> tuple[GoalStatus, StateMachineResult | None]:
            assert await client.wait_for_server(10.0), "the action server was not found"
            goal = client.send_goal(StateMachineGoal("idle", "go", "resend_module"))
            status = await asyncio.wait_for(goal.wait(), 10.0)
            return status, goal.result

        status, result = session.clock.run(trip())
        assert len(refused) == 2, "the middleware was not asked to send the result"
        assert status is GoalStatus.SUCCEEDED and result == StateMachineResult("done", "ok")
    finally:
        module.shutdown()
        controller.shutdown()
