"""What the dashboard and the API read from a robot, whether it runs in this process or over ROS.

The in-process :class:`~cyborg.app.robot.Robot` satisfies :class:`RobotView` directly; under
ROS the ``cyborg_api`` node builds a mirror of the other nodes (``cyborg.web.ros_view``)
that satisfies it too, so the dashboard has one typed way to read either.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from cyborg.controller.runtime import ControllerStats, Phase
from cyborg.storage import SaveStatus
from cyborg.transport.base import GoalStatus, Node
from cyborg.transport.messages import SystemState

if TYPE_CHECKING:
    from cyborg.app.config import LoadedConfig
    from cyborg.maps import OccupancyMap

__all__ = ["BaseStatus", "BaseView", "ControllerView", "RobotView"]


@dataclass(frozen=True)
class BaseStatus:
    """Where the base is and what it does; a value is None where the base does not say."""

    x: float | None = None
    y: float | None = None
    theta: float | None = None
    route: Sequence[tuple[float, float]] | None = None
    path_state: str | None = None
    wandering: bool | None = None
    distance_travelled: float | None = None

    @property
    def has_pose(self) -> bool:
        return all(v is not None and math.isfinite(v) for v in (self.x, self.y, self.theta))


@runtime_checkable
class BaseView(Protocol):
    """A robot base the dashboard can draw: its map and its status."""

    @property
    def map(self) -> OccupancyMap: ...

    def status(self) -> BaseStatus: ...


class ControllerView(Protocol):
    """The controller's state as the dashboard shows it."""

    @property
    def node(self) -> Node: ...

    @property
    def active_state(self) -> str | None: ...

    @property
    def previous_state(self) -> str: ...

    @property
    def last_event(self) -> str: ...

    @property
    def phase(self) -> Phase: ...

    @property
    def goal_status(self) -> GoalStatus | None: ...

    @property
    def stats(self) -> ControllerStats: ...

    @property
    def last_feedback_at(self) -> Mapping[str, float]:
        """Clock time (``clock.now()``) of each module's last feedback, by action or module name."""
        ...

    def add_state_listener(self, listener: Callable[[SystemState], None]) -> None: ...


class RobotView(Protocol):
    """A whole robot as the dashboard reads it."""

    @property
    def config(self) -> LoadedConfig: ...

    @property
    def controller(self) -> ControllerView: ...

    def emotion_enabled(self) -> bool | None:
        """Whether the emotion system is on; None where that is not known."""
        ...

    def save_status(self) -> SaveStatus | None:
        """Whether the controller's data is being saved; None where that is not known."""
        ...

    def loop_blocked(self) -> dict[str, Any] | None:
        """The last time a callback blocked the robot's event loop (see cyborg.transport.watchdog);
        None if never, or where not watched (a ROS node per module)."""
        ...

    def base(self) -> BaseView | None:
        """The robot's base, if the dashboard can draw it."""
        ...

    def module_actions(self) -> Mapping[str, Sequence[str]]:
        """Each module's node name and the actions it serves (without the leading slash)."""
        ...
