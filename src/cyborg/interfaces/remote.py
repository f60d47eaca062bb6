"""A robot seen from outside: what the dashboard needs, rebuilt from the ROS graph.

In ``cyborg sim`` the dashboard reads the in-process controller and base. As a
ROS node (``cyborg node cyborg_api``) it has neither, so these mirrors follow
the state changes, the base's pose and path state on their topics, the last
on/off sent to the emotion system, and load the same map file the simulated
base uses. Not on the wire, so not shown under ROS: the goal status of the
active module, the controller's counters beyond handovers, and the base's
planned route.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from cyborg.controller.config import LoadedConfig
from cyborg.controller.runtime import ControllerStats, Phase
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.messages import PoseWithCovarianceStamped, String, SystemState


class ControllerMirror:
    """Follows ``state_change``: active and previous state, last event. Counters are not on the wire."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.active_state: str | None = None
        self.previous_state = ""
        self.last_event = ""
        self.goal_status = None
        self.stats = ControllerStats()
        self._listeners: list[Any] = []
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_change, queue_size=1000)

    @property
    def phase(self) -> Phase:
        return Phase.ACTIVE if self.active_state else Phase.STOPPED

    def add_state_listener(self, listener: Any) -> None:
        self._listeners.append(listener)

    def _on_change(self, message: SystemState, info: MessageInfo) -> None:
        self.previous_state, self.active_state = message.from_system_state, message.to_system_state
        self.last_event = message.event
        self.stats.handovers += 1
        for listener in self._listeners:
            listener(message)


class EmotionSwitchMirror:
    """Whether the emotion system is on: the parameter it keeps (``emotion_enabled``).

    ``enabled`` is None while no emotion system has set the parameter (none has started yet).
    """

    def __init__(self, node: Node) -> None:
        self.node = node

    @property
    def enabled(self) -> bool | None:
        value = self.node.get_param(topics.EMOTION_ENABLED_PARAM, None)
        return value if isinstance(value, bool) else None


class BaseMirror:
    """Follows the base's pose and path state; ``map`` is loaded from the same file."""

    def __init__(self, node: Node, occupancy_map: Any) -> None:
        self.map = occupancy_map
        self.x = self.y = self.theta = math.nan
        self.route = None
        self.path_state: str | None = None
        node.subscribe(topics.AMCL_POSE, PoseWithCovarianceStamped, self._on_pose, queue_size=10)
        node.subscribe(topics.ARNL_PATH_STATE, String, self._on_path_state)

    def _on_pose(self, message: PoseWithCovarianceStamped, info: MessageInfo) -> None:
        pose = message.pose.pose
        self.x, self.y = pose.position.x, pose.position.y
        q = pose.orientation
        self.theta = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))

    def _on_path_state(self, message: String, info: MessageInfo) -> None:
        self.path_state = message.data


@dataclass
class RemoteRobot:
    """The attributes of :class:`cyborg.sim.robot.Robot` the dashboard reads."""

    config: LoadedConfig
    controller: ControllerMirror
    components: dict[str, object] = field(default_factory=dict)
    emotion: Any = None


def remote_robot(node: Node, config: LoadedConfig, occupancy_map: Any | None) -> RemoteRobot:
    robot = RemoteRobot(config=config, controller=ControllerMirror(node), emotion=EmotionSwitchMirror(node))
    if occupancy_map is not None:
        robot.components["rosarnl_node"] = BaseMirror(node, occupancy_map)
    return robot
