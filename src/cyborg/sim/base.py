"""The simulated robot base: stands in for ROSARNL and MobileSim (thesis 2.7).

It offers the ROSARNL interface the navigation module uses: the action
``/rosarnl_node/move_base`` (goal: a pose in the map frame; feedback: the
current pose), the services ``/rosarnl_node/wander`` and ``/rosarnl_node/stop``
(std_srvs/Empty), the pose on ``/rosarnl_node/amcl_pose`` and the path state on
``/rosarnl_node/arnl_path_state``. Routes come from :class:`RoutePlanner`; the robot drives
them at a set speed on the injected clock. Registered as the module kind ``simulated_base``.

With ``base_api: nav2`` (the default on a ROS 2 graph) it offers nav2's action ``/navigate_to_pose``
(our NavigateToPose interface) instead of ``move_base`` and the two services: goal a pose,
feedback the current pose and the distance left along the route, an abort's reason in the
result's ``error_msg``. A goal whose ``behavior_tree`` is ``wander`` wanders until it is
cancelled; cancelling a goal stops the base.

The pose moves in steps of ``1 / pose_rate`` seconds along each leg of a route (10 a second, as
ROSARNL's), and each step is published. With ``virtual_pose_rate`` set, on a virtual clock that
runs as fast as it can (``--speed max``) only every ``pose_rate / virtual_pose_rate``-th step,
the end of each leg and the pose it stops at are published; the steps between still happen, at
the same clock times, so where the base is at each moment, where it stops when halted and when it
arrives do not change. What changes is what its subscribers see: a transcript's pose records
(at most one a second) are sampled from fewer poses, and the navigation module's idea of where
the robot is, which its calendar scheduler reads, can be up to ``1 / virtual_pose_rate`` s old.
:meth:`SimulatedBase.status` (the dashboard) reads the current step.
"""

from __future__ import annotations

import asyncio
import enum
import itertools
import logging
import math
import random
from collections.abc import Coroutine, Sequence
from typing import Any

from pydantic import Field

from cyborg.app.view import BaseStatus
from cyborg.errors import InvalidValueError, PlanningError
from cyborg.maps import NamedPose, OccupancyMap, Point
from cyborg.modules.kind import BuildContext, ModuleKind, ModuleSettings
from cyborg.sim.planner import RoutePlanner
from cyborg.sim.search_ahead import SearchAhead
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node, ServerGoalHandle
from cyborg.transport.messages import (
    EmptyRequest,
    EmptyResponse,
    EmptyService,
    Header,
    MoveBaseAction,
    MoveBaseFeedback,
    MoveBaseGoal,
    MoveBaseResult,
    NavigateToPoseAction,
    NavigateToPoseFeedback,
    NavigateToPoseGoal,
    NavigateToPoseResult,
    Pose,
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    String,
)
from cyborg.transport.messages import (
    Point as PointMsg,
)
from cyborg.transport.topics import BaseApi

log = logging.getLogger(__name__)

DEFAULT_POSE_RATE = 10.0
"""Pose updates a second while moving (ROSARNL publishes its pose at about 10 Hz)."""
MAP_FRAME = "map"

_MoveHandle = ServerGoalHandle[MoveBaseGoal, MoveBaseResult, MoveBaseFeedback]
_NavigateHandle = ServerGoalHandle[NavigateToPoseGoal, NavigateToPoseResult, NavigateToPoseFeedback]
_AnyHandle = ServerGoalHandle[Any, Any, Any]


class PathState(enum.Enum):
    """ROSARNL's path states, as published on ``arnl_path_state``."""

    NOT_INITIALIZED = "NOT_INITIALIZED"
    PLANNING_PATH = "PLANNING_PATH"
    MOVING_TO_GOAL = "MOVING_TO_GOAL"
    REACHED_GOAL = "REACHED_GOAL"
    FAILED_PLAN = "FAILED_PLAN"
    ABORTED_PATHPLAN = "ABORTED_PATHPLAN"
    WANDERING = "WANDERING"
    STOPPED = "STOPPED"


def yaw_to_quaternion(theta: float) -> Quaternion:
    return Quaternion(0.0, 0.0, math.sin(theta / 2.0), math.cos(theta / 2.0))


def quaternion_to_yaw(q: Quaternion) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def pose_stamped(x: float, y: float, theta: float, stamp: float = 0.0) -> PoseStamped:
    return PoseStamped(
        Header(stamp=stamp, frame_id=MAP_FRAME), Pose(PointMsg(x, y, 0.0), yaw_to_quaternion(theta))
    )


class SimulatedBase:
    """A Pioneer LX on a map: plans, drives, wanders, reports its pose.

    ``pose_rate``: pose steps a second while moving, each published in real time;
    ``virtual_pose_rate``: pose messages a second on a clock that runs as fast as it can (see the
    module's docstring).
    """

    def __init__(
        self,
        node: Node,
        occupancy_map: OccupancyMap,
        *,
        rng: random.Random,
        speed: float = 0.6,
        robot_radius: float = 0.35,
        start: NamedPose | Point | None = None,
        planner: RoutePlanner | None = None,
        pose_rate: float = DEFAULT_POSE_RATE,
        virtual_pose_rate: float | None = None,
        search_ahead: bool = True,
        base_api: BaseApi = BaseApi.ROSARNL,
    ) -> None:
        if speed <= 0:
            raise InvalidValueError(f"speed must be positive (m/s), got {speed}")
        for name, rate in (("pose_rate", pose_rate), ("virtual_pose_rate", virtual_pose_rate or 1.0)):
            if not (math.isfinite(rate) and rate > 0):
                raise InvalidValueError(f"{name} must be a positive number of poses a second, got {rate!r}")
        self.tick = 1.0 / pose_rate
        """Seconds between pose steps while moving."""
        self.steps_per_message = 1
        """Pose steps per published pose: ``pose_rate / virtual_pose_rate`` on a clock that runs as fast
        as it can, else 1 (every step)."""
        if virtual_pose_rate is not None and node.clock.as_fast_as_possible:
            self.steps_per_message = max(1, round(pose_rate / virtual_pose_rate))
        self.node = node
        self.map = occupancy_map
        self.planner = planner or RoutePlanner(occupancy_map, robot_radius)
        self.rng = rng
        self.speed = speed
        self._ahead = (
            SearchAhead(self.planner, node.clock) if search_ahead and node.clock.as_fast_as_possible else None
        )
        """Wander trips searched ahead on a second process, at --speed max only (the same routes)."""
        start_pose = start if start is not None else _default_start(occupancy_map)
        if isinstance(start_pose, NamedPose):
            self.x, self.y, self.theta = start_pose.x, start_pose.y, start_pose.theta
        else:
            self.x, self.y, self.theta = start_pose[0], start_pose[1], 0.0
        if not self.planner.is_free(self.x, self.y):
            free = self.planner.nearest_free_point((self.x, self.y))
            if free is not None:
                log.warning(
                    "the start (%.1f, %.1f) is inside a wall or within %.2f m of one; the simulated base starts "
                    "at the nearest free place (%.1f, %.1f); fix: give the map a RobotHome or a goal named "
                    "'information desk', or set start: to a named pose",
                    self.x,
                    self.y,
                    self.planner.robot_radius,
                    *free,
                )
                self.x, self.y = free
        self.route: list[Point] | None = None
        self.path_state = PathState.NOT_INITIALIZED
        self.distance_travelled = 0.0
        self.wandering = False
        self._failure = ""
        self._motion: asyncio.Task[bool] | None = None
        self._goal: _AnyHandle | None = None
        self._leg = 0  # the route's waypoint the base drives to now
        self._unpublished = False  # a step was made since the last pose message (virtual_pose_rate)
        self._stepped = False  # the last pose went out as a step: the latched one is older
        self._heading = (math.nan, Quaternion())  # the last heading published, and its quaternion
        # Where it rests (its start, the end of each leg, where it stops) is latched for late
        # subscribers; the steps between go out unlatched. On ROS 2 a latched message reaches each
        # of our subscriptions twice (its volatile and its transient-local half, one copy dropped):
        # at 10 steps a second that doubled what hearing the pose cost its three listeners.
        self._pose_pub = node.publisher(topics.AMCL_POSE, PoseWithCovarianceStamped, latch=True)
        self._step_pub = node.publisher(topics.AMCL_POSE, PoseWithCovarianceStamped)
        self._state_pub = node.publisher(topics.ARNL_PATH_STATE, String, latch=True)
        self.base_api = base_api
        """The interface it offers: ROSARNL's services and ``move_base``, or nav2's action."""
        if base_api is BaseApi.NAV2:
            node.action_server(
                topics.NAVIGATE_TO_POSE, NavigateToPoseAction, self._on_navigate, self._on_cancel
            )
        else:
            node.action_server(topics.MOVE_BASE, MoveBaseAction, self._on_goal, self._on_cancel)
            node.advertise_service(topics.WANDER, EmptyService, self._on_wander)
            node.advertise_service(topics.STOP, EmptyService, self._on_stop)
        self._publish_pose()
        self._set_state(PathState.STOPPED)

    def close(self) -> None:
        """Stop driving (a goal under way ends as preempted) and the process searching ahead."""
        self._halt()
        if self._ahead is not None:
            self._ahead.close()

    def status(self) -> BaseStatus:
        """Pose (the current step, also between published poses), route and path state, for the
        dashboard (a :class:`~cyborg.app.view.BaseView`)."""
        return BaseStatus(
            x=self.x,
            y=self.y,
            theta=self.theta,
            route=[(float(p[0]), float(p[1])) for p in self.route] if self.route is not None else None,
            path_state=self.path_state.value,
            wandering=self.wandering,
            distance_travelled=self.distance_travelled,
        )

    # --- outputs ----------------------------------------------------------------------

    def _publish_pose(self, *, resting: bool = True) -> None:
        """Publish the pose: latched where the base rests (or may: a leg's end), else a step."""
        self._unpublished = False
        self._stepped = not resting
        if self._heading[0] != self.theta:  # messages are frozen: one orientation serves a whole leg
            self._heading = (self.theta, yaw_to_quaternion(self.theta))
        pose = Pose(PointMsg(self.x, self.y, 0.0), self._heading[1])
        header = Header(stamp=self.node.clock.now(), frame_id=MAP_FRAME)
        (self._pose_pub if resting else self._step_pub).publish(
            PoseWithCovarianceStamped(header, PoseWithCovariance(pose))
        )

    def _set_state(self, state: PathState) -> None:
        if state is not self.path_state:
            self.path_state = state
            self._state_pub.publish(String(state.value))

    # --- motion -------------------------------------------------------------------------

    def _halt(self) -> None:
        if self._motion is not None and not self._motion.done():
            self._motion.cancel()
            if self._unpublished or self._stepped:
                self._publish_pose()  # where it stops, latched (or that step was not published)
        self._motion = None
        self.route = None
        self.wandering = False

    async def _drive(self, target: tuple[float, float], heading: float | None, on_pose: Any = None) -> bool:
        """Plan and drive to ``target``; False if there is no route."""
        self._set_state(PathState.PLANNING_PATH)
        try:
            route = self.planner.plan((self.x, self.y), target, self._ahead)
        except PlanningError as exc:
            self._set_state(PathState.FAILED_PLAN)
            self._failure = str(exc)
            return False
        self.route = list(route.waypoints)
        self._set_state(PathState.WANDERING if self.wandering else PathState.MOVING_TO_GOAL)
        for self._leg, waypoint in enumerate(route.waypoints[1:], 1):
            await self._drive_leg(waypoint, on_pose)
        if heading is not None:
            self.theta = heading
            self._publish_pose()
        self.route = None
        return True

    async def _drive_leg(self, waypoint: Point, on_pose: Any) -> None:
        clock = self.node.clock
        loop = clock.loop
        dx, dy = waypoint[0] - self.x, waypoint[1] - self.y
        length = math.hypot(dx, dy)
        if length < 1e-9:
            return
        self.theta = math.atan2(dy, dx)
        sx, sy = self.x, self.y
        duration = length / self.speed
        start = clock.monotonic()
        done = 0.0
        unpublished = 0  # steps made since the last published one
        arrived: asyncio.Future[None] = loop.create_future()
        timer: asyncio.Handle

        # Each step is a timer callback rather than a sleep of this coroutine: the same clock times,
        # with no future, task wake-up or extra loop turn for each of the ~10 steps a second.
        def step() -> None:
            nonlocal done, unpublished, timer
            if arrived.done():  # the drive was cancelled in this loop turn, before the step came
                return
            elapsed = clock.monotonic() - start
            # The pose follows the clock, not the number of ticks: a tick that comes late (a loaded
            # machine, virtual time at 25x) moves the robot further, so a trip takes the same
            # virtual time however the ticks fall. Within a millisecond of the end counts as there:
            # a clock far from its origin may not move at all for a sleep of a few nanoseconds.
            fraction = 1.0 if elapsed >= duration - 1e-3 else elapsed / duration
            self.x, self.y = sx + dx * fraction, sy + dy * fraction
            self.distance_travelled += length * (fraction - done)
            done = fraction
            unpublished += 1
            self._unpublished = True
            if unpublished == self.steps_per_message or done >= 1.0:
                unpublished = 0
                self._publish_pose(resting=done >= 1.0)
                if on_pose is not None:
                    on_pose()
            if done >= 1.0:
                arrived.set_result(None)
            else:
                timer = schedule()

        def schedule() -> asyncio.Handle:
            delay = min(self.tick, max(0.0, duration - (clock.monotonic() - start)))
            return loop.call_later(delay, step) if delay > 0 else loop.call_soon(step)

        timer = schedule()
        try:
            await arrived
        finally:
            timer.cancel()

    # --- move_base ----------------------------------------------------------------------

    def _on_goal(self, handle: _MoveHandle) -> None:
        def feedback() -> None:
            if not handle.status.is_terminal:
                handle.publish_feedback(
                    MoveBaseFeedback(pose_stamped(self.x, self.y, self.theta, self.node.clock.now()))
                )

        self._take_goal(handle)
        self._start_motion(handle, self._drive_to(handle.goal.target_pose.pose, feedback), "move_base")

    def _take_goal(self, handle: _AnyHandle) -> None:
        if self._goal is not None and not self._goal.status.is_terminal:
            self._goal.canceled(text="replaced by a new goal")
        self._halt()
        handle.accept()
        self._goal = handle
        self._failure = ""

    def _drive_to(self, pose: Pose, on_pose: Any) -> Coroutine[Any, Any, bool]:
        return self._drive((pose.position.x, pose.position.y), quaternion_to_yaw(pose.orientation), on_pose)

    def _start_motion(self, handle: _AnyHandle, motion: Coroutine[Any, Any, bool], name: str) -> None:
        task = self.node.clock.loop.create_task(motion, name=name)
        task.add_done_callback(lambda done: self._finish_goal(handle, done))
        self._motion = task

    # --- navigate_to_pose (ROS 2) ---------------------------------------------------------

    def _on_navigate(self, handle: _NavigateHandle) -> None:
        started = self.node.clock.monotonic()

        def feedback() -> None:
            if not handle.status.is_terminal:
                remaining = self._distance_remaining()
                handle.publish_feedback(
                    NavigateToPoseFeedback(
                        current_pose=pose_stamped(self.x, self.y, self.theta, self.node.clock.now()),
                        navigation_time=self.node.clock.monotonic() - started,
                        estimated_time_remaining=remaining / self.speed,
                        distance_remaining=remaining,
                    )
                )

        self._take_goal(handle)
        if handle.goal.behavior_tree == topics.WANDER_BEHAVIOR:
            self.wandering = True
            self._start_motion(handle, self._wander(feedback), "wander")
        else:
            self._start_motion(handle, self._drive_to(handle.goal.pose.pose, feedback), "navigate_to_pose")

    def _distance_remaining(self) -> float:
        """Metres along the route still to drive (0 when there is none)."""
        route = self.route
        if not route or self._leg >= len(route):
            return 0.0
        ahead = math.dist((self.x, self.y), route[self._leg])
        return ahead + sum(math.dist(a, b) for a, b in itertools.pairwise(route[self._leg :]))

    def _finish_goal(self, handle: _AnyHandle, task: asyncio.Task[bool]) -> None:
        if handle.status.is_terminal:
            return
        if task.cancelled():
            handle.canceled(text="stopped")
            self._set_state(PathState.STOPPED)
        elif task.exception() is not None:
            log.error("move_base failed", exc_info=task.exception())
            handle.abort(text=f"internal error: {task.exception()!r}")
            self._set_state(PathState.ABORTED_PATHPLAN)
        elif task.result():
            self._set_state(PathState.REACHED_GOAL)
            handle.succeed(NavigateToPoseResult() if self.base_api is BaseApi.NAV2 else MoveBaseResult())
        else:
            log.info("navigation goal aborted: %s", self._failure)
            handle.abort(self._failed_result(), text=self._failure)

    def _failed_result(self) -> NavigateToPoseResult | None:
        return NavigateToPoseResult(error_msg=self._failure) if self.base_api is BaseApi.NAV2 else None

    def _on_cancel(self, handle: _AnyHandle) -> None:
        if handle.status.is_terminal:
            return  # finished already: a late cancel must not stop what the base does now (wandering)
        if handle is self._goal:
            self._halt()
            self._set_state(PathState.STOPPED)
        handle.canceled(text="stopped")

    # --- wander / stop ------------------------------------------------------------------

    def _on_wander(self, request: EmptyRequest, info: MessageInfo) -> EmptyResponse:
        if self._goal is not None and not self._goal.status.is_terminal:
            self._goal.canceled(text="wandering instead")
        self._halt()
        self.wandering = True
        self._motion = self.node.clock.loop.create_task(self._wander(), name="wander")
        return EmptyResponse()

    async def _wander(self, on_pose: Any = None) -> bool:
        while self.wandering:
            try:
                target = self.planner.random_reachable_point(self.rng, near=(self.x, self.y))
            except PlanningError as exc:
                log.warning("cannot wander: %s; the base stays where it is", exc)
                self.wandering = False
                self._failure = str(exc)
                return False
            if self._ahead is not None:
                self._ahead.foresee_wander(self.rng, target)
            if not await self._drive(target, None, on_pose):
                await self.node.clock.sleep(1.0)
        return True

    def _on_stop(self, request: EmptyRequest, info: MessageInfo) -> EmptyResponse:
        if self._goal is not None and not self._goal.status.is_terminal:
            self._halt()
        else:
            self._halt()
            self._set_state(PathState.STOPPED)
        return EmptyResponse()


START_PLACES = ("information desk", "info")
"""Named goals the robot starts at when the map has one: the Cyborg's post is the information desk
(thesis 10.2.1 obs. 0, "The Cyborg is located at the information desk")."""


def _default_start(occupancy_map: OccupancyMap) -> NamedPose | Point:
    """Where the robot starts without ``start``: the information desk, else RobotHome, Dock, any pose,
    the middle of the map."""
    names = {pose.name for pose in occupancy_map.poses}
    for name in START_PLACES:
        if name in names:
            return occupancy_map.pose(name)
    for kind in ("RobotHome", "Dock"):
        for pose in occupancy_map.poses:
            if pose.kind == kind:
                return pose
    if occupancy_map.poses:
        return occupancy_map.poses[0]
    return occupancy_map.cell_to_world(*[n // 2 for n in occupancy_map.shape])


def named_locations(occupancy_map: OccupancyMap) -> Sequence[NamedPose]:
    return [pose for pose in occupancy_map.poses if pose.kind in ("GoalWithHeading", "Goal")]


class SimulatedBaseSettings(ModuleSettings):
    """A simulated Pioneer LX on the robot's map, with ROSARNL's interface (stands in for the real base)."""

    speed: float = Field(0.6, gt=0, description="driving speed in m/s")
    pose_rate: float = Field(
        DEFAULT_POSE_RATE,
        gt=0,
        le=1000,
        description="pose steps a second while moving, each published on amcl_pose (and as move_base "
        "feedback) unless virtual_pose_rate says otherwise; ROSARNL publishes about 10",
    )
    virtual_pose_rate: float | None = Field(
        None,
        gt=0,
        le=1000,
        description="pose messages a second while moving at --speed max (scenario scripts, benchmarks; "
        "at most pose_rate; default: every step). 1 makes a simulated day faster (a transcript "
        "records one pose a second anyway); the steps still come at pose_rate, so the base goes the "
        "same way, but the navigation module's calendar scheduler may see a pose up to 1 s old",
    )
    robot_radius: float = Field(0.35, ge=0, description="metres kept from walls when planning")
    search_ahead: bool = Field(
        True,
        description="at --speed max, search the next wander trips' routes on a second process while "
        "the base drives (the same routes; a simulated day ~20 % faster; a process of about 80 MB)",
    )
    start: str | None = Field(
        None, description="named pose to start at (default: the information desk, else RobotHome or Dock)"
    )
    base_api: BaseApi | None = Field(
        None,
        description="the interface it offers: rosarnl (move_base, wander, stop) or nav2 "
        "(navigate_to_pose); default: the graph's (nav2 on ROS 2, rosarnl otherwise)",
    )


def _build(node: Node, settings: SimulatedBaseSettings, context: BuildContext) -> SimulatedBase:
    occupancy = context.occupancy_map()
    start = occupancy.pose(settings.start) if settings.start else None
    return SimulatedBase(
        node,
        occupancy,
        rng=context.rng,
        speed=settings.speed,
        robot_radius=settings.robot_radius,
        start=start,
        pose_rate=settings.pose_rate,
        virtual_pose_rate=settings.virtual_pose_rate,
        search_ahead=settings.search_ahead,
        base_api=settings.base_api or context.base_api,
    )


KIND = ModuleKind(SimulatedBaseSettings, _build)
