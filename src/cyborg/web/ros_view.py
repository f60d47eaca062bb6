"""A robot seen from outside: what the dashboard needs, rebuilt from the ROS graph.

In ``cyborg sim`` the dashboard reads the in-process controller and base. As a
ROS node (``cyborg node cyborg_api``) it has neither, so these mirrors follow
the state changes, the base's pose and path state on their topics, the last
on/off sent to the emotion system, and load the same map file the simulated
base uses. The controller's counters come as JSON on ``/cyborg_controller/stats``
(published by ``cyborg node cyborg_controller``, see :func:`publish_controller_stats`).
Not on the wire, so not shown under ROS: the goal status of the active module
and the base's planned route.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from cyborg.app.config import LoadedConfig
from cyborg.app.view import BaseStatus, BaseView
from cyborg.controller.runtime import Controller, ControllerStats, Phase
from cyborg.errors import TransportError
from cyborg.maps import OccupancyMap
from cyborg.storage import SaveStatus
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, MessageInfo, Node, Publisher
from cyborg.transport.guards import OnlyFrom
from cyborg.transport.messages import PoseWithCovarianceStamped, String, SystemState

log = logging.getLogger(__name__)

STATS_PERIOD = 1.0  # clock seconds between looks at the controller's counters


async def publish_controller_stats(publisher: Publisher[String], controller: Controller) -> None:
    """Publish ``controller``'s counters as JSON whenever they changed (looked at every
    STATS_PERIOD), for ever; the publisher should be latched so a late API node gets the last."""
    last: dict[str, int] | None = None
    while True:
        counters = dataclasses.asdict(controller.stats)
        if counters != last:
            publisher.publish(String(data=json.dumps(counters)))
            last = counters
        await controller.node.clock.sleep(STATS_PERIOD)


class ControllerMirror:
    """Follows ``state_change`` (active and previous state, last event) and the controller's
    counters on ``/cyborg_controller/stats``; until those arrive it counts handovers itself.
    Only the controller's node is believed: a state change another node publishes (a stranger,
    another robot on the graph) is counted in ``foreign`` and logged once per sender."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.active_state: str | None = None
        self.previous_state = ""
        self.last_event = ""
        self.goal_status: GoalStatus | None = None
        self.stats = ControllerStats()
        self.last_feedback_at: dict[str, float] = {}  # not published under ROS
        self._listeners: list[Callable[[SystemState], None]] = []
        self.foreign = OnlyFrom(topics.CONTROLLER_NODE, topics.STATE_CHANGE, "state changes")
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_change, queue_size=1000)
        node.subscribe(topics.CONTROLLER_STATS, String, self._on_stats, queue_size=10)

    @property
    def phase(self) -> Phase:
        return Phase.ACTIVE if self.active_state else Phase.STOPPED

    def add_state_listener(self, listener: Callable[[SystemState], None]) -> None:
        self._listeners.append(listener)

    def _on_change(self, message: SystemState, info: MessageInfo) -> None:
        if not self.foreign.accepts(info.sender):
            return
        self.previous_state, self.active_state = message.from_system_state, message.to_system_state
        self.last_event = message.event
        self.stats.handovers += 1
        for listener in self._listeners:
            listener(message)

    def _on_stats(self, message: String, info: MessageInfo) -> None:
        try:
            counters = json.loads(message.data)
        except ValueError:
            log.warning("%s sent counters that are not JSON: %.80r", info.sender, message.data)
            return
        if not isinstance(counters, dict):
            return
        for name in (f.name for f in dataclasses.fields(self.stats)):
            value = counters.get(name)
            if isinstance(value, int) and not isinstance(value, bool):
                setattr(self.stats, name, value)


class EmotionSwitchMirror:
    """Whether the emotion system is on: the parameter it keeps (``emotion_enabled``).

    ``enabled`` is None while no emotion system has set the parameter (none has started yet).
    """

    def __init__(self, node: Node) -> None:
        self.node = node

    @property
    def enabled(self) -> bool | None:
        """None too while it cannot be read (the ROS master is away): the status is served anyway."""
        try:
            value = self.node.get_param(topics.EMOTION_ENABLED_PARAM, None)
        except TransportError:
            return None
        return value if isinstance(value, bool) else None


class BaseMirror:
    """Follows the base's pose and path state; ``map`` is loaded from the same file."""

    def __init__(self, node: Node, occupancy_map: OccupancyMap) -> None:
        self.map = occupancy_map
        self.x = self.y = self.theta = math.nan
        self.path_state: str | None = None
        node.subscribe(topics.AMCL_POSE, PoseWithCovarianceStamped, self._on_pose, queue_size=10)
        node.subscribe(topics.ARNL_PATH_STATE, String, self._on_path_state)

    def status(self) -> BaseStatus:
        """The last pose and path state heard (no route: ROSARNL does not publish it)."""
        return BaseStatus(x=self.x, y=self.y, theta=self.theta, path_state=self.path_state)

    def _on_pose(self, message: PoseWithCovarianceStamped, info: MessageInfo) -> None:
        pose = message.pose.pose
        self.x, self.y = pose.position.x, pose.position.y
        q = pose.orientation
        self.theta = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))

    def _on_path_state(self, message: String, info: MessageInfo) -> None:
        self.path_state = message.data


@dataclass
class RemoteRobot:
    """The other nodes of a ROS robot as the dashboard reads them (a :class:`RobotView`)."""

    config: LoadedConfig
    controller: ControllerMirror
    switch: EmotionSwitchMirror
    base_mirror: BaseMirror | None = None

    def emotion_enabled(self) -> bool | None:
        return self.switch.enabled

    def save_status(self) -> SaveStatus | None:
        return None  # the store is the controller node's; it does not publish its state

    def loop_blocked(self) -> dict[str, Any] | None:
        return None  # each module has its own process and loop there

    def base(self) -> BaseView | None:
        return self.base_mirror

    def module_actions(self) -> dict[str, list[str]]:
        return {"rosarnl_node": []} if self.base_mirror is not None else {}


def remote_robot(node: Node, config: LoadedConfig, occupancy_map: OccupancyMap | None) -> RemoteRobot:
    """A mirror of the robot whose nodes run elsewhere, read over ``node``."""
    base = BaseMirror(node, occupancy_map) if occupancy_map is not None else None
    return RemoteRobot(config, ControllerMirror(node), EmotionSwitchMirror(node), base)
