"""A base that fails quietly: it never answers a goal, or its pose goes silent while it drives.

The robot of tests/navigation/test_module.py with the real robot's limits (robot.yaml's
``base_answer_timeout`` and ``pose_timeout``) and a simulated base that fails in one of these
ways. The robot gives the trip up within the limit, stops the base, says it is stuck, logs what is
wrong with the fix, and is ready for the next person.
"""

from __future__ import annotations

import json
import logging
import typing
from pathlib import Path

import pytest
import yaml

from cyborg.app.config import LoadedConfig, packaged_config, parse_config
from cyborg.modules.kind import BuildContext, ModuleKind
from cyborg.sim.base import SimulatedBase, SimulatedBaseSettings
from cyborg.transport import topics
from cyborg.transport.base import Node
from cyborg.transport.clock import VirtualClock
from cyborg.transport.messages import String
from tests.navigation.test_module import CONFIG, Cyborg, planner_for

ROBOT = yaml.safe_load(packaged_config("robot.yaml").read_text())["modules"]["cyborg_navigation"]
ANSWER_TIMEOUT = float(ROBOT["base_answer_timeout"])
POSE_TIMEOUT = float(ROBOT["pose_timeout"])


def robot_limits() -> LoadedConfig:
    raw = yaml.safe_load(CONFIG.read_text())
    raw["motivator"]["events"] = []
    raw["modules"]["cyborg_idle"]["boredom"] = [0.0, 0.0, 0.0]
    raw["modules"]["cyborg_navigation"] = ROBOT
    return parse_config(yaml.safe_dump(raw), source=str(CONFIG))


class DeafBase(SimulatedBase):
    """Offers move_base but never takes a goal (a hung base node)."""

    def _on_goal(self, handle: typing.Any) -> None:
        return None


class BlindBase(SimulatedBase):
    """Drives, but its pose stops 2 s after a goal starts (localisation gone)."""

    def _on_goal(self, handle: typing.Any) -> None:
        self._blind_from = self.node.clock.monotonic() + 2.0
        super()._on_goal(handle)

    def _publish_pose(self, *, resting: bool = True) -> None:
        if self.node.clock.monotonic() < getattr(self, "_blind_from", float("inf")):
            super()._publish_pose(resting=resting)


def faulty(cls: type[SimulatedBase]) -> dict[str, ModuleKind[typing.Any]]:
    def build(node: Node, settings: SimulatedBaseSettings, robot: BuildContext) -> SimulatedBase:
        occupancy = robot.occupancy_map()
        return cls(
            node, occupancy, rng=robot.rng, speed=settings.speed, planner=planner_for(occupancy.source)
        )

    return {"simulated_base": ModuleKind(SimulatedBaseSettings, build)}


@pytest.mark.parametrize(
    ("base", "limit", "problem"),
    [
        (DeafBase, ANSWER_TIMEOUT, "has not answered the goal on /rosarnl_node/move_base"),
        (BlindBase, 2.0 + POSE_TIMEOUT, "pose on /rosarnl_node/amcl_pose has been silent"),
    ],
)
def test_a_base_failing_quietly_ends_the_trip_within_its_limit_and_the_robot_says_so(
    clock: VirtualClock,
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
    base: type[SimulatedBase],
    limit: float,
    problem: str,
) -> None:
    cyborg = Cyborg(clock, tmp_path, kinds=faulty(base), config=robot_limits())
    problems: list[dict[str, typing.Any]] = []  # what the dashboard is told (cyborg.modules.problems)
    cyborg.transport.node("dashboard_probe").subscribe(
        topics.PROBLEMS, String, lambda m, i: problems.append(json.loads(m.data))
    )
    try:

        async def main() -> float:
            await cyborg.settle()
            await cyborg.order("go to the cafeteria")
            await cyborg.until(lambda: cyborg.state == "navigation_moving", 10.0, "moving")
            moving = clock.monotonic()
            await cyborg.until(lambda: cyborg.state == "idle", limit + 30.0, "the trip given up")
            ended = next(t for t, a, e, _ in cyborg.states if a == "navigation_moving" and e == "aborted")
            where = cyborg.position
            await clock.sleep(10.0)
            assert cyborg.position == where, "the base drove on after the trip was given up"
            # and the robot still serves the next person: it answers a question
            since = clock.monotonic()
            cyborg.hear("where is the elevator")
            await cyborg.until(lambda: len(cyborg.sentences(since)) > 0, 15.0, "an answer")
            return ended - moving

        with caplog.at_level(logging.WARNING):
            took = clock.run(main())
    finally:
        cyborg.transport.shutdown()
    assert limit - 0.1 <= took <= limit + limit / 4 + 0.1, took
    assert ("navigation_moving", "aborted", "navigation_talking") in cyborg.transitions()
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any(problem in w and "fix:" in w for w in warnings), warnings
    [told] = problems  # once, while the robot goes on
    assert told["module"] == "cyborg_navigation"
    [open_problem] = told["open"]
    assert open_problem["key"] == "base" and problem in open_problem["problem"] and open_problem["fix"]
