"""The simulated robot base (ROSARNL stand-in, thesis 2.7.2) on the embedded transport in virtual time.

A client drives it the way the navigation module does: goals on
``/rosarnl_node/move_base``, the ``wander`` and ``stop`` services, and what it
reports on ``amcl_pose`` and ``arnl_path_state``.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from cyborg.errors import PlanningError
from cyborg.maps import Cell, NamedPose, OccupancyMap, Point, load_map
from cyborg.sim.base import PathState, SimulatedBase, pose_stamped, quaternion_to_yaw
from cyborg.sim.planner import RoutePlanner
from cyborg.transport import topics
from cyborg.transport.base import ClientGoalHandle, GoalStatus, MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import (
    EmptyService,
    MoveBaseAction,
    MoveBaseFeedback,
    MoveBaseGoal,
    MoveBaseResult,
    PoseWithCovarianceStamped,
    String,
)
from tests.support.paths import GLASSGARDEN

SPEED = 0.6
ARRIVED = 0.1  # metres: "the pose ends there"

MoveHandle = ClientGoalHandle[MoveBaseGoal, MoveBaseResult, MoveBaseFeedback]


class Client:
    """What the navigation module sees of the base: poses, path states, the action and the services."""

    def __init__(self, transport: EmbeddedTransport, name: str = "test_client") -> None:
        self.clock = transport.clock
        node = transport.node(name)
        self.poses: list[tuple[float, float, float, float]] = []  # (t, x, y, theta)
        self.states: list[str] = []
        self.feedback: list[Point] = []
        node.subscribe(topics.AMCL_POSE, PoseWithCovarianceStamped, self._on_pose, queue_size=10_000)
        node.subscribe(topics.ARNL_PATH_STATE, String, self._on_state, queue_size=1000)
        self.move_base = node.action_client(topics.MOVE_BASE, MoveBaseAction)
        self.wander = node.service_proxy(topics.WANDER, EmptyService)
        self.stop = node.service_proxy(topics.STOP, EmptyService)

    def _on_pose(self, message: PoseWithCovarianceStamped, info: MessageInfo) -> None:
        p = message.pose.pose
        yaw = quaternion_to_yaw(p.orientation)
        self.poses.append((self.clock.monotonic(), p.position.x, p.position.y, yaw))

    def _on_state(self, message: String, info: MessageInfo) -> None:
        self.states.append(message.data)

    def _on_feedback(self, feedback: MoveBaseFeedback) -> None:
        position = feedback.base_position.pose.position
        self.feedback.append((position.x, position.y))

    @property
    def position(self) -> Point:
        return (self.poses[-1][1], self.poses[-1][2])

    def send(self, x: float, y: float, theta: float = 0.0) -> MoveHandle:
        return self.move_base.send_goal(
            MoveBaseGoal(pose_stamped(x, y, theta, self.clock.now())), on_feedback=self._on_feedback
        )

    def send_to(self, place: NamedPose) -> MoveHandle:
        return self.send(place.x, place.y, place.theta)


def make_base(
    transport: EmbeddedTransport,
    occupancy_map: OccupancyMap,
    planner: RoutePlanner,
    *,
    start: str = "information desk",
    seed: int = 7,
    virtual_pose_rate: float | None = 1.0,
) -> SimulatedBase:
    return SimulatedBase(
        transport.node("rosarnl_node"),
        occupancy_map,
        rng=random.Random(seed),
        speed=SPEED,
        planner=planner,
        start=occupancy_map.pose(start),
        virtual_pose_rate=virtual_pose_rate,
    )


def a_wall_point(occupancy_map: OccupancyMap, near: Point) -> Point:
    """The centre of the wall cell nearest ``near``."""
    rows, cols = np.nonzero(occupancy_map.grid == Cell.OCCUPIED)
    centres = [occupancy_map.cell_to_world(int(r), int(c)) for r, c in zip(rows, cols, strict=True)]
    return min(centres, key=lambda point: math.dist(point, near))


def test_move_base_to_a_named_place_arrives_after_distance_over_speed(
    clock: VirtualClock, transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    base = make_base(transport, campus, campus_planner)
    client = Client(transport)
    cafeteria = campus.pose("cafeteria")
    route = campus_planner.plan((base.x, base.y), cafeteria)

    async def main() -> tuple[GoalStatus, float]:
        await clock.sleep(0.1)
        started = clock.monotonic()
        status = await client.send_to(cafeteria).wait()
        return status, clock.monotonic() - started

    status, took = clock.run(main())
    assert status is GoalStatus.SUCCEEDED
    x, y = client.position
    assert math.dist((x, y), cafeteria.position) < ARRIVED
    assert client.poses[-1][3] == pytest.approx(cafeteria.theta, abs=1e-6)  # faces the goal's heading
    assert route.length > 50  # a real trip across the campus, not a hop
    assert took == pytest.approx(route.length / SPEED, abs=0.5)
    assert base.distance_travelled == pytest.approx(route.length, rel=1e-6)


def test_late_ticks_do_not_slow_the_trip_down(
    clock: VirtualClock,
    transport: EmbeddedTransport,
    campus: OccupancyMap,
    campus_planner: RoutePlanner,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """On a loaded machine at 25x every sleep wakes late; the trip still takes distance / speed
    (scenario C over ROS reached the cafeteria 40 s late and in another mood)."""
    base = make_base(transport, campus, campus_planner)
    client = Client(transport)
    cafeteria = campus.pose("cafeteria")
    route = campus_planner.plan((base.x, base.y), cafeteria)
    on_time = clock.sleep

    async def late(delay: float) -> None:
        await on_time(delay * 1.5 + 0.01)

    monkeypatch.setattr(clock, "sleep", late)

    async def main() -> float:
        started = clock.monotonic()
        await client.send_to(cafeteria).wait()
        return clock.monotonic() - started

    took = clock.run(main())
    assert math.dist(client.position, cafeteria.position) < ARRIVED
    assert took == pytest.approx(route.length / SPEED, abs=0.5)
    assert base.distance_travelled == pytest.approx(route.length, rel=1e-6)


def test_feedback_reports_poses_along_the_way(
    clock: VirtualClock, transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    make_base(transport, campus, campus_planner, virtual_pose_rate=None)  # every step, as in real time
    client = Client(transport)
    entrance = campus.pose("entrance")
    start = campus.pose("information desk").position

    async def main() -> GoalStatus:
        await clock.sleep(0.1)
        return await client.send_to(entrance).wait()

    assert clock.run(main()) is GoalStatus.SUCCEEDED
    trip = campus_planner.plan(start, entrance).length / SPEED
    assert len(client.feedback) >= trip / 0.1 - 5  # about one per tick
    assert math.dist(client.feedback[0], start) <= SPEED * 0.1 + 1e-6  # the first step out
    assert math.dist(client.feedback[-1], entrance.position) < ARRIVED
    steps = [math.dist(a, b) for a, b in zip(client.feedback, client.feedback[1:], strict=False)]
    assert max(steps) <= SPEED * 0.1 + 1e-6  # it drives, it does not jump
    assert all(campus_planner.is_free(x, y) for x, y in client.feedback)


def test_cancel_mid_way_stops_the_robot_and_preempts(
    clock: VirtualClock, transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    base = make_base(transport, campus, campus_planner)
    client = Client(transport)
    start = (base.x, base.y)

    async def main() -> tuple[GoalStatus, str, Point, int]:
        await clock.sleep(0.1)
        handle = client.send_to(campus.pose("cafeteria"))
        await clock.sleep(5.0)
        handle.cancel()
        status = await handle.wait()
        stopped_at, count = client.position, len(client.poses)
        await clock.sleep(20.0)
        return status, handle.text, stopped_at, count

    status, text, stopped_at, count = clock.run(main())
    assert status is GoalStatus.PREEMPTED
    assert text == "stopped"
    assert math.dist(stopped_at, start) == pytest.approx(5.0 * SPEED, abs=0.2)  # it had moved
    assert len(client.poses) == count and client.position == stopped_at  # and moves no more
    assert base.path_state is PathState.STOPPED
    assert client.states[-1] == PathState.STOPPED.value  # the path state says so too


@pytest.mark.parametrize("virtual_pose_rate", [None, 1.0], ids=["every step", "one a second"])
def test_a_late_subscriber_hears_where_the_base_stopped(
    clock: VirtualClock,
    transport: EmbeddedTransport,
    campus: OccupancyMap,
    campus_planner: RoutePlanner,
    virtual_pose_rate: float | None,
) -> None:
    """The steps go out unlatched (a latched message costs its ROS 2 listeners twice); where the
    base rests is latched: a dashboard started after a trip was cancelled sees where it stopped."""
    base = make_base(transport, campus, campus_planner, virtual_pose_rate=virtual_pose_rate)
    client = Client(transport)

    async def main() -> tuple[Point, list[tuple[float, float, float, float]]]:
        await clock.sleep(0.1)
        handle = client.send_to(campus.pose("cafeteria"))
        await clock.sleep(5.0)
        handle.cancel()
        await handle.wait()
        await clock.sleep(1.0)
        late = Client(transport, "late_client")
        await clock.sleep(0.1)
        return client.position, late.poses

    stopped_at, heard_late = clock.run(main())
    assert len(heard_late) == 1
    assert (heard_late[0][1], heard_late[0][2]) == stopped_at == (base.x, base.y)


def test_stop_service_stops_a_goal_with_preempted(
    clock: VirtualClock, transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    make_base(transport, campus, campus_planner)
    client = Client(transport)

    async def main() -> tuple[GoalStatus, Point]:
        await clock.sleep(0.1)
        handle = client.send_to(campus.pose("cafeteria"))
        await clock.sleep(4.0)
        await client.stop.call()
        status = await handle.wait()
        stopped_at = client.position
        await clock.sleep(10.0)
        assert client.position == stopped_at
        return status, stopped_at

    status, _ = clock.run(main())
    assert status is GoalStatus.PREEMPTED
    assert client.states[-1] == PathState.STOPPED.value


def test_goal_inside_a_wall_aborts_with_the_planners_reason(
    clock: VirtualClock, transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    base = make_base(transport, campus, campus_planner)
    client = Client(transport)
    wall = a_wall_point(campus, campus.pose("cafeteria").position)
    with pytest.raises(PlanningError) as expected:
        campus_planner.plan((base.x, base.y), wall)

    async def main() -> tuple[GoalStatus, str]:
        await clock.sleep(0.1)
        handle = client.send(*wall)
        status = await handle.wait()
        await clock.sleep(5.0)
        return status, handle.text

    status, text = clock.run(main())
    assert status is GoalStatus.ABORTED
    assert text == str(expected.value)
    assert "inside a wall" in text
    assert client.position == campus.pose("information desk").position  # it never moved
    assert client.states[-2:] == [PathState.PLANNING_PATH.value, PathState.FAILED_PLAN.value]


def test_goal_off_the_map_aborts_saying_so(
    clock: VirtualClock, transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    make_base(transport, campus, campus_planner)
    client = Client(transport)

    async def main() -> MoveHandle:
        await clock.sleep(0.1)
        handle = client.send(500.0, -400.0)
        await handle.wait()
        return handle

    handle = clock.run(main())
    assert handle.status is GoalStatus.ABORTED
    assert "off the map" in handle.text and "(500.0, -400.0)" in handle.text
    assert client.states[-1] == PathState.FAILED_PLAN.value


def test_a_new_goal_replaces_the_running_one(
    clock: VirtualClock, transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    make_base(transport, campus, campus_planner)
    client = Client(transport)
    entrance = campus.pose("entrance")

    async def main() -> tuple[MoveHandle, MoveHandle]:
        await clock.sleep(0.1)
        first = client.send_to(campus.pose("cafeteria"))
        await clock.sleep(3.0)
        second = client.send_to(entrance)
        await second.wait()
        await clock.sleep(5.0)
        return first, second

    first, second = clock.run(main())
    assert first.status is GoalStatus.PREEMPTED
    assert first.text == "replaced by a new goal"
    assert second.status is GoalStatus.SUCCEEDED
    assert math.dist(client.position, entrance.position) < ARRIVED  # and it stays there
    assert client.states[-1] == PathState.REACHED_GOAL.value


def test_path_states_of_a_trip(
    clock: VirtualClock, transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    make_base(transport, campus, campus_planner)
    client = Client(transport)

    async def main() -> None:
        await clock.sleep(0.1)
        await client.send_to(campus.pose("waiting area")).wait()

    clock.run(main())
    assert client.states == [
        PathState.STOPPED.value,  # latched at start-up
        PathState.PLANNING_PATH.value,
        PathState.MOVING_TO_GOAL.value,
        PathState.REACHED_GOAL.value,
    ]


def wander_run(
    campus: OccupancyMap,
    planner: RoutePlanner,
    seed: int,
    seconds: float = 120.0,
    virtual_pose_rate: float | None = 1.0,
) -> tuple[list[tuple[float, float, float, float]], list[str]]:
    """Poses and path states while wandering ``seconds``, then stopping, on a fresh clock."""
    clock = VirtualClock()
    try:
        transport = EmbeddedTransport(clock)
        make_base(transport, campus, planner, seed=seed, virtual_pose_rate=virtual_pose_rate)
        client = Client(transport)

        async def main() -> None:
            await clock.sleep(0.1)
            await client.wander.call()
            await clock.sleep(seconds)
            await client.stop.call()
            await clock.sleep(10.0)

        clock.run(main())
        return client.poses, client.states
    finally:
        clock.close()


def test_wander_keeps_moving_to_random_places_until_stopped(
    campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    seconds = 400.0
    poses, states = wander_run(campus, campus_planner, seed=3, seconds=seconds)
    moving = [p for p in poses if p[0] <= seconds + 0.1]
    after_stop = [p for p in poses if p[0] > seconds + 0.2]
    assert after_stop == []  # stop ends it: no pose changes afterwards
    places = states.count(PathState.PLANNING_PATH.value)  # one plan per random place
    assert places >= 4, states
    assert states.count(PathState.WANDERING.value) == places
    spread = max(math.dist(a[1:3], b[1:3]) for a in moving[::50] for b in moving[::50])
    assert spread > 10.0  # it gets around
    assert moving[-1][0] > seconds - 1.0  # still moving right up to the stop
    assert states[-1] == PathState.STOPPED.value


def test_wander_is_deterministic_for_a_seed(campus: OccupancyMap, campus_planner: RoutePlanner) -> None:
    first, _ = wander_run(campus, campus_planner, seed=11, seconds=60.0)
    again, _ = wander_run(campus, campus_planner, seed=11, seconds=60.0)
    other, _ = wander_run(campus, campus_planner, seed=3, seconds=60.0)
    assert first == again
    assert len({(x, y) for _, x, y, _ in first}) > 50  # it did move (about a pose a second)
    assert first != other  # the places come from the random generator


def test_the_pose_rate_changes_how_often_it_says_where_it_is_not_where_it_goes(
    campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    """With virtual_pose_rate 1 at --speed max the base publishes a pose a second instead of every
    step: the same trips, the same poses at the same times, the same place it stops at."""
    every_step, states = wander_run(campus, campus_planner, seed=5, seconds=90.3, virtual_pose_rate=None)
    a_second, same_states = wander_run(campus, campus_planner, seed=5, seconds=90.3)
    assert same_states == states
    assert len(every_step) > 5 * len(a_second) > 300
    steps = {round(t, 6): (x, y, theta) for t, x, y, theta in every_step}
    for t, x, y, theta in a_second[:-1]:
        assert steps[round(t, 6)] == (x, y, theta)  # a step it also made, at the same time
    assert a_second[-1][1:] == every_step[-1][1:]  # stopped at the same step (said when stopped)


def test_a_goal_ends_wandering(
    clock: VirtualClock, transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    base = make_base(transport, campus, campus_planner)
    client = Client(transport)
    elevator = campus.pose("elevator")

    async def main() -> GoalStatus:
        await clock.sleep(0.1)
        await client.wander.call()
        await clock.sleep(30.0)
        assert base.wandering
        status = await client.send_to(elevator).wait()
        await clock.sleep(30.0)
        return status

    assert clock.run(main()) is GoalStatus.SUCCEEDED
    assert not base.wandering
    assert math.dist(client.position, elevator.position) < ARRIVED  # it stays: wandering is over
    after_goal = client.states[client.states.index(PathState.WANDERING.value) :]
    assert after_goal[-3:] == [
        PathState.PLANNING_PATH.value,
        PathState.MOVING_TO_GOAL.value,
        PathState.REACHED_GOAL.value,
    ]


def test_glassgarden_info_to_cafeteria(clock: VirtualClock, transport: EmbeddedTransport) -> None:
    glassgarden = load_map(GLASSGARDEN)
    planner = RoutePlanner(glassgarden, 0.35)
    make_base(transport, glassgarden, planner, start="info")
    client = Client(transport)
    cafeteria = glassgarden.pose("cafeteria")
    route = planner.plan(glassgarden.pose("info"), cafeteria)

    async def main() -> tuple[GoalStatus, float]:
        await clock.sleep(0.1)
        started = clock.monotonic()
        status = await client.send_to(cafeteria).wait()
        return status, clock.monotonic() - started

    status, took = clock.run(main())
    assert status is GoalStatus.SUCCEEDED
    assert math.dist(client.position, cafeteria.position) < ARRIVED
    assert took == pytest.approx(route.length / SPEED, abs=0.5)
    assert all(planner.is_free(x, y) for _, x, y, _ in client.poses)  # never through a wall


def test_without_a_start_it_starts_at_the_information_desk(
    transport: EmbeddedTransport, campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    """The issue: the information desk is the start (the campus map's RobotHome is 2.5 m away)."""
    base = SimulatedBase(transport.node("rosarnl_node"), campus, rng=random.Random(1), planner=campus_planner)
    desk = campus.pose("information desk")
    assert (base.x, base.y, base.theta) == (desk.x, desk.y, desk.theta)
    client = Client(transport)
    transport.clock.run(transport.clock.sleep(0.1))
    assert client.position == desk.position  # what the navigation module hears


def test_on_glassgarden_it_starts_at_info_not_at_a_robot_home(transport: EmbeddedTransport) -> None:
    glassgarden = load_map(GLASSGARDEN)
    base = SimulatedBase(transport.node("rosarnl_node"), glassgarden, rng=random.Random(1))
    assert (base.x, base.y) == glassgarden.pose("info").position


def test_a_map_without_an_information_desk_starts_at_its_robot_home(transport: EmbeddedTransport) -> None:
    grid = np.zeros((40, 40), dtype=np.uint8)
    poses = (NamedPose("lab", 1.0, 1.0, 0.0), NamedPose("home", 3.0, 2.0, 1.0, kind="RobotHome"))
    plain = OccupancyMap(grid=grid, resolution=0.1, origin=(0.0, 0.0), poses=poses)
    base = SimulatedBase(transport.node("rosarnl_node"), plain, rng=random.Random(1), robot_radius=0.1)
    assert (base.x, base.y, base.theta) == (3.0, 2.0, 1.0)
