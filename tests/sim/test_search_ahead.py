"""Wander routes searched ahead on a second process (issue 18): the same routes, the worker's
searches used, the worker gone with the clock, and a worker that dies changes nothing but speed."""

from __future__ import annotations

import logging
import multiprocessing
import os
import random
import signal

import pytest

from cyborg.maps import OccupancyMap
from cyborg.sim.base import SimulatedBase
from cyborg.sim.planner import RoutePlanner
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import EmptyService, PoseWithCovarianceStamped

Pose = tuple[float, float, float, float]


def wander(
    campus: OccupancyMap,
    planner: RoutePlanner,
    *,
    search_ahead: bool,
    seconds: float = 900.0,
    kill_worker_at: float | None = None,
    speed: float | None = None,
) -> tuple[list[Pose], SimulatedBase]:
    """Every pose step of a base wandering ``seconds`` (seed 21); the clock is closed at the end."""
    clock = VirtualClock(speed=speed)
    poses: list[Pose] = []
    try:
        transport = EmbeddedTransport(clock)
        base = SimulatedBase(
            transport.node("rosarnl_node"),
            campus,
            rng=random.Random(21),
            planner=planner,
            start=campus.pose("information desk"),
            search_ahead=search_ahead,
        )
        node = transport.node("watcher")

        def on_pose(m: PoseWithCovarianceStamped, info: MessageInfo) -> None:
            p = m.pose.pose
            poses.append((clock.monotonic(), p.position.x, p.position.y, p.orientation.z))

        node.subscribe(topics.AMCL_POSE, PoseWithCovarianceStamped, on_pose, queue_size=100_000)
        wander_service = node.service_proxy(topics.WANDER, EmptyService)

        async def main() -> None:
            await wander_service.call()
            if kill_worker_at is not None:
                await clock.sleep(kill_worker_at)
                for worker in multiprocessing.active_children():
                    os.kill(worker.pid or 0, signal.SIGKILL)
                await clock.sleep(seconds - kill_worker_at)
            else:
                await clock.sleep(seconds)

        clock.run(main())
    finally:
        clock.close()
    return poses, base


def test_routes_searched_ahead_are_the_routes_searched_here(
    campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    here, without = wander(campus, campus_planner, search_ahead=False)
    ahead, base = wander(campus, campus_planner, search_ahead=True)
    assert without._ahead is None
    assert base._ahead is not None and base._ahead.used >= 3, "the worker's searches were not used"
    assert len(here) > 5000
    assert ahead == here  # every step of every trip, at the same clock times


def test_closing_the_clock_stops_the_worker(campus: OccupancyMap, campus_planner: RoutePlanner) -> None:
    before = {p.pid for p in multiprocessing.active_children()}
    _, base = wander(campus, campus_planner, search_ahead=True, seconds=300.0)
    assert base._ahead is not None and base._ahead.used >= 1
    assert {p.pid for p in multiprocessing.active_children()} <= before, "the worker outlived its clock"


def test_a_worker_that_dies_leaves_the_base_searching_by_itself(
    campus: OccupancyMap, campus_planner: RoutePlanner, caplog: pytest.LogCaptureFixture
) -> None:
    here, _ = wander(campus, campus_planner, search_ahead=False)
    with caplog.at_level(logging.WARNING, logger="cyborg.sim.search_ahead"):
        after_kill, _ = wander(campus, campus_planner, search_ahead=True, kill_worker_at=200.0)
    assert after_kill == here
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "searches each route itself" in warnings[0], warnings


def test_only_a_clock_running_as_fast_as_it_can_searches_ahead(
    campus: OccupancyMap, campus_planner: RoutePlanner
) -> None:
    """At a speed (a ROS launch at 25x) the base waits for the clock anyway: no second process."""
    _, base = wander(campus, campus_planner, search_ahead=True, seconds=5.0, speed=100.0)
    assert base._ahead is None
