"""The simulated base's ROS 2 interface, nav2's ``navigate_to_pose`` (``base_api: nav2``), on the
embedded transport in virtual time.

A client drives it as the navigation module does on ROS 2: a goal with a pose drives there
(feedback: the pose and the distance left), a goal with ``behavior_tree: wander`` wanders until
cancelled. The robot's navigation module runs scenario A over that interface with the checks of
the embedded run; over real ROS 2 processes, see tests/ros2/test_ros2_robot.py.
"""

from __future__ import annotations

import importlib.util
import itertools
import math
import random
from collections.abc import Iterator
from pathlib import Path

import pytest

from cyborg.app.config import load_config, packaged_config
from cyborg.maps import OccupancyMap, default_map_path, load_map
from cyborg.sim import scenario
from cyborg.sim.base import SimulatedBase, pose_stamped
from cyborg.sim.planner import RoutePlanner
from cyborg.sim.script import load_script
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import NavigateToPoseAction, NavigateToPoseFeedback, NavigateToPoseGoal
from cyborg.transport.topics import BaseApi

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


@pytest.fixture
def ros2_transport(clock: VirtualClock) -> Iterator[EmbeddedTransport]:
    transport = EmbeddedTransport(clock)
    yield transport
    transport.shutdown()


@pytest.fixture(scope="module")
def campus() -> OccupancyMap:
    return load_map(default_map_path())


def test_navigate_to_pose_arrives_reporting_the_distance_left(
    clock: VirtualClock, ros2_transport: EmbeddedTransport, campus: OccupancyMap
) -> None:
    planner = RoutePlanner(campus, 0.35)
    base = SimulatedBase(
        ros2_transport.node("rosarnl_node"),
        campus,
        base_api=BaseApi.NAV2,
        rng=random.Random(1),
        planner=planner,
        start=campus.pose("information desk"),
    )
    client = ros2_transport.node("client").action_client(topics.NAVIGATE_TO_POSE, NavigateToPoseAction)
    cafeteria = campus.pose("cafeteria")
    length = planner.plan((base.x, base.y), cafeteria.position).length
    feedback: list[NavigateToPoseFeedback] = []

    async def main() -> GoalStatus:
        assert await client.wait_for_server(1.0)
        goal = NavigateToPoseGoal(pose=pose_stamped(cafeteria.x, cafeteria.y, cafeteria.theta))
        return await client.send_goal(goal, on_feedback=feedback.append).wait()

    assert clock.run(main()) is GoalStatus.SUCCEEDED
    assert math.dist((base.x, base.y), cafeteria.position) < 0.1
    left = [f.distance_remaining for f in feedback]
    assert left[0] == pytest.approx(length, abs=0.6 * 0.1 + 1e-6)  # one step out
    assert left[-1] == pytest.approx(0.0, abs=1e-6)
    assert all(a >= b for a, b in itertools.pairwise(left))  # it only gets closer
    last = feedback[-1].current_pose.pose.position
    assert math.dist((last.x, last.y), cafeteria.position) < 0.1
    assert feedback[-1].navigation_time == pytest.approx(length / 0.6, abs=0.5)


def test_a_wander_goal_wanders_until_cancelled_then_stops(
    clock: VirtualClock, ros2_transport: EmbeddedTransport, campus: OccupancyMap
) -> None:
    base = SimulatedBase(
        ros2_transport.node("rosarnl_node"), campus, rng=random.Random(2), base_api=BaseApi.NAV2
    )
    client = ros2_transport.node("client").action_client(topics.NAVIGATE_TO_POSE, NavigateToPoseAction)

    async def main() -> tuple[GoalStatus, float, tuple[float, float]]:
        goal = client.send_goal(NavigateToPoseGoal(behavior_tree=topics.WANDER_BEHAVIOR))
        await clock.sleep(60)
        assert goal.status is GoalStatus.ACTIVE and base.wandering
        travelled = base.distance_travelled
        goal.cancel()
        status = await goal.wait()
        stopped_at = (base.x, base.y)
        await clock.sleep(10)
        assert (base.x, base.y) == stopped_at  # it stands still after the cancel
        return status, travelled, stopped_at

    status, travelled, _ = clock.run(main())
    assert status is GoalStatus.PREEMPTED
    assert travelled > 0.5 * 0.6 * 60  # it drove most of the minute
    assert not base.wandering and base.status().path_state == "STOPPED"


def test_an_unreachable_pose_aborts_saying_why(
    clock: VirtualClock, ros2_transport: EmbeddedTransport, campus: OccupancyMap
) -> None:
    SimulatedBase(ros2_transport.node("rosarnl_node"), campus, rng=random.Random(3), base_api=BaseApi.NAV2)
    client = ros2_transport.node("client").action_client(topics.NAVIGATE_TO_POSE, NavigateToPoseAction)

    async def main() -> tuple[GoalStatus, str, str]:
        goal = client.send_goal(NavigateToPoseGoal(pose=pose_stamped(1e6, 1e6, 0.0)))
        status = await goal.wait()
        assert goal.result is not None
        return status, goal.result.error_msg, goal.text

    status, error, text = clock.run(main())
    assert status is GoalStatus.ABORTED
    assert error and error == text


def test_scenario_a_with_the_ros2_navigation_interface(
    tmp_path: Path,
) -> None:
    """The navigation module drives and wanders through navigate_to_pose (no move_base, no
    wander service on the graph) and scenario A passes the embedded run's checks."""
    spec = importlib.util.spec_from_file_location("nav2_expectations", SCENARIOS / "expectations.py")
    assert spec is not None and spec.loader is not None
    expectations = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(expectations)
    config = load_config(packaged_config("cyborg.yaml"))
    for raw in config.model.modules.values():
        if isinstance(raw, dict) and raw.get("kind") in ("navigation", "simulated_base"):
            raw["base_api"] = "nav2"
    records = scenario.run_scenario(
        config,
        load_script(SCENARIOS / "scenario_a.yaml"),
        data_dir=tmp_path,
    )
    expectations.CHECKS["scenario_a"](records)
