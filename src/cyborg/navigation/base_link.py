"""How the navigation module drives the robot base: ROSARNL's interface, or nav2's.

ROSARNL (the Pioneer LX's, on ROS 1 and in process): the action ``move_base`` takes a pose, the
services ``wander`` and ``stop`` start and end wandering (thesis 2.7). nav2 (the default on
ROS 2): the ``navigate_to_pose`` action (our NavigateToPose interface); a goal with a pose drives
there, a goal whose ``behavior_tree`` is ``wander`` wanders until it is cancelled, so ending the
wander cancels that goal. :func:`base_link` makes the one the module's ``base_api`` names.
"""

from __future__ import annotations

import asyncio
import math
from typing import Any, Protocol

from cyborg.errors import CyborgError
from cyborg.transport import topics
from cyborg.transport.base import ClientGoalHandle, GoalStatus, Node
from cyborg.transport.messages import (
    EmptyService,
    Header,
    MoveBaseAction,
    MoveBaseGoal,
    NavigateToPoseAction,
    NavigateToPoseGoal,
    Point,
    Pose,
    PoseStamped,
    Quaternion,
)
from cyborg.transport.topics import BaseApi

__all__ = ["BaseLink", "Nav2Link", "RosarnlLink", "base_link"]

CALL_TIMEOUT = 5.0
"""Seconds a wander's start or stop waits for the base."""

Goal = ClientGoalHandle[Any, Any, Any]


class BaseLink(Protocol):
    """What the navigation module asks of the robot base."""

    name: str
    """The action it drives through (named when the base is missing)."""

    async def ready(self, timeout: float) -> bool:
        """True once the base offers its action (within ``timeout`` clock seconds)."""

    def go(self, x: float, y: float, heading: float) -> Goal:
        """Drive to the pose; the goal succeeds on arrival."""

    async def wander(self) -> None:
        """Start wandering (raises CyborgError when the base does not answer)."""

    async def stop(self) -> None:
        """Stop the wander (raises CyborgError when the base does not answer)."""


def _target(node: Node, x: float, y: float, heading: float) -> PoseStamped:
    return PoseStamped(
        Header(stamp=node.clock.now(), frame_id="map"),
        Pose(Point(x, y, 0.0), Quaternion(0.0, 0.0, math.sin(heading / 2), math.cos(heading / 2))),
    )


class RosarnlLink:
    """ROSARNL's ``move_base`` action and ``wander``/``stop`` services (ROS 1)."""

    name = topics.MOVE_BASE

    def __init__(self, node: Node) -> None:
        self.node = node
        self.move_base = node.action_client(topics.MOVE_BASE, MoveBaseAction)
        self._wander = node.service_proxy(topics.WANDER, EmptyService)
        self._stop = node.service_proxy(topics.STOP, EmptyService)

    async def ready(self, timeout: float) -> bool:
        return await self.move_base.wait_for_server(timeout)

    def go(self, x: float, y: float, heading: float) -> Goal:
        return self.move_base.send_goal(MoveBaseGoal(_target(self.node, x, y, heading)))

    async def wander(self) -> None:
        await self._wander.call(timeout=CALL_TIMEOUT)

    async def stop(self) -> None:
        await self._stop.call(timeout=CALL_TIMEOUT)


class Nav2Link:
    """nav2's ``navigate_to_pose`` action (ROS 2): wandering is a goal that runs until cancelled."""

    name = topics.NAVIGATE_TO_POSE

    def __init__(self, node: Node) -> None:
        self.node = node
        self.navigate = node.action_client(topics.NAVIGATE_TO_POSE, NavigateToPoseAction)
        self._wandering: Goal | None = None

    async def ready(self, timeout: float) -> bool:
        return await self.navigate.wait_for_server(timeout)

    def go(self, x: float, y: float, heading: float) -> Goal:
        return self.navigate.send_goal(NavigateToPoseGoal(pose=_target(self.node, x, y, heading)))

    async def wander(self) -> None:
        if not await self.ready(CALL_TIMEOUT):
            raise CyborgError(f"cannot wander: no robot base offers {self.name}; fix: start the base's node")
        self._wandering = self.navigate.send_goal(NavigateToPoseGoal(behavior_tree=topics.WANDER_BEHAVIOR))

    async def stop(self) -> None:
        goal, self._wandering = self._wandering, None
        if goal is None or goal.status.is_terminal:
            return
        goal.cancel()
        try:
            await asyncio.wait_for(goal.wait(), CALL_TIMEOUT)  # the loop's time is the clock's
        except TimeoutError:
            raise CyborgError(
                f"the base did not stop within {CALL_TIMEOUT:g} s: its wander goal on {self.name} "
                f"is still {goal.status.name}"
            ) from None
        if goal.status is GoalStatus.ABORTED:
            raise CyborgError(f"the base's wander ended with an error: {goal.text}")


def base_link(node: Node, api: BaseApi = BaseApi.ROSARNL) -> BaseLink:
    """The base's interface ``api`` on ``node``'s graph."""
    return Nav2Link(node) if api is BaseApi.NAV2 else RosarnlLink(node)
