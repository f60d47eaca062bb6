"""The ``navigation`` module kind: its settings and how it is built from the robot's map.

The factory opens the navigation database (``<data dir>/navigation.db`` unless ``db:``
names another), makes the map's goals its places, and starts :class:`NavigationModule`.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import Field

from cyborg.modules.kind import BuildContext, ModuleKind, ModuleSettings
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.keywords import ALL_TRIGGERS, NO_PHRASES, YES_PHRASES, Intent
from cyborg.navigation.module import MOVING_ACTION, PLANNING_ACTION, TALKING_ACTION, NavigationModule
from cyborg.transport.base import Node
from cyborg.transport.topics import BaseApi


class NavigationSettings(ModuleSettings):
    """Guides people to places (thesis 7): answers questions, follows the calendar, wanders."""

    db: str | None = Field(None, description="navigation database (default: <data dir>/navigation.db)")
    scheduler_interval: float = Field(10.0, gt=0, description="seconds between looks at the calendar")
    scheduler_repeat: float = Field(
        20.0, gt=0, description="seconds before the calendar may raise the same event again"
    )
    answer_timeout: float = Field(20.0, gt=0, description="seconds it waits for a yes or no")
    feedback_interval: float = Field(15.0, gt=0, description="seconds between emotion feedbacks on a trip")
    wander_limit: float = Field(600.0, gt=0, description="seconds a wander lasts at most")
    base_api: BaseApi | None = Field(
        None,
        description="the robot base's interface: rosarnl (move_base, wander, stop) or nav2 "
        "(navigate_to_pose); default: the graph's (nav2 on ROS 2, rosarnl otherwise)",
    )

    base_answer_timeout: float | None = Field(
        None,
        gt=0,
        description="seconds the base may take to accept a goal before the trip is given up "
        "(default: no limit; the real robot's configuration sets one)",
    )
    pose_timeout: float | None = Field(
        None,
        gt=0,
        description="seconds of silence on the pose topic while driving before the robot stops and "
        "gives the trip up (default: no limit; the real robot's configuration sets one)",
    )

    def serves(self) -> tuple[str, ...]:
        return (PLANNING_ACTION, MOVING_ACTION, TALKING_ACTION)

    def publishes(self) -> tuple[str, ...]:
        """What it hears asked (a place), what the calendar raises, and how its trips go on."""
        heard = tuple(intent.value for intent in Intent if intent not in (Intent.YES, Intent.NO))
        return (
            *heard,
            "navigation_scheduler",
            "navigation_start_moving",
            "navigation_start_wandering",
            "navigation_wandering_completed",
            "navigation_feedback_completed",
        )

    def speaks_in(self) -> tuple[str, ...]:
        return self.serves()

    def listens_for(self) -> tuple[str, ...]:
        """The phrases that start a request for a place (the place follows them), and the answers."""
        return (*ALL_TRIGGERS, *YES_PHRASES, *NO_PHRASES)

    def listens_for_places(self) -> tuple[str, ...]:
        """The phrases a place follows: "go to", "where is", "what do you think of" ..."""
        return ALL_TRIGGERS


def _build(node: Node, settings: NavigationSettings, context: BuildContext) -> NavigationModule:
    db = NavigationDatabase(Path(settings.db) if settings.db else context.data_dir / "navigation.db")
    occupancy = context.occupancy_map()
    map_name = Path(occupancy.source).stem if occupancy.source else "map"
    db.use_map(map_name)  # also for a map without goals: the last map's places are not on this one
    for goal in occupancy.poses:
        if goal.kind in ("Goal", "GoalWithHeading"):
            db.import_pose(goal, map_name)
    module = NavigationModule(
        node,
        db,
        rng=context.rng,
        scheduler_interval=settings.scheduler_interval,
        scheduler_repeat=settings.scheduler_repeat,
        answer_timeout=settings.answer_timeout,
        feedback_interval=settings.feedback_interval,
        wander_limit=settings.wander_limit,
        base_api=settings.base_api or context.base_api,
        base_answer_timeout=settings.base_answer_timeout,
        pose_timeout=settings.pose_timeout,
    )
    module.owns_db = True
    return module


KIND = ModuleKind(NavigationSettings, _build)
