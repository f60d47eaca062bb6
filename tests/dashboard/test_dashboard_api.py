"""The dashboard's JSON endpoints and map image, on an in-process robot (no browser)."""

from __future__ import annotations

import struct
import zlib
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from aiohttp import ClientSession

from cyborg.app.config import load_config
from cyborg.app.robot import Robot, build_robot
from cyborg.app.view import BaseStatus
from cyborg.emotion.model import EmotionSettings
from cyborg.emotion.system import EmotionSystem
from cyborg.maps import Cell, KeepOutZone, NamedPose, OccupancyMap
from cyborg.modules.behaviour import HEARTBEAT_SECONDS
from cyborg.transport import topics
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String
from cyborg.web.api import RobotAPI
from cyborg.web.dashboard import (
    MAP_COLOURS,
    NO_BASE,
    png_bytes,
    pooled_grid,
    register,
    remaining_route,
    route_points,
)
from cyborg.web.ros_view import remote_robot

MACHINE = """
initial: idle
timeouts: {connect: 0.5, preempt: 0.5}
states:
  idle: {action: cyborg_idle/idle, transitions: {music_play: music, aborted: idle}}
  music: {action: cyborg_music/play, transitions: {succeeded: idle, aborted: idle}}
modules:
  cyborg_idle: {kind: idle}
  cyborg_music: {kind: placeholder, servers: [{action: cyborg_music/play, duration: 30}]}
"""


class FakeBase:
    """Stands in for the simulated base: a BaseView (its map and its status)."""

    def __init__(self, occupancy: OccupancyMap, route: Any) -> None:
        self.map = occupancy
        self.route = route
        self.x: float | None = None
        self.y: float | None = None
        self.theta: float | None = None

    def status(self) -> BaseStatus:
        return BaseStatus(x=self.x, y=self.y, theta=self.theta, route=self.route)


def small_map() -> OccupancyMap:
    grid = np.zeros((4, 6), dtype=np.uint8)  # row 0 is the southern edge
    grid[0, :] = Cell.OCCUPIED
    grid[3, 5] = Cell.UNKNOWN
    return OccupancyMap(
        grid=grid,
        resolution=0.5,
        origin=(-1.0, -2.0),
        poses=(NamedPose("cafeteria", 1.0, -0.5, 0.0, kind="GoalWithHeading"),),
        keep_out=(KeepOutZone(((0.0, 0.0), (0.5, 0.0), (0.5, 0.5)), name="stairs"),),
        source="/somewhere/small.map",
    )


Fetch = Callable[[str], Awaitable[tuple[int, Any]]]


def serve(tmp_path: Path, base: object | None, check: Callable[[Fetch, Robot], Awaitable[None]]) -> None:
    """Start a robot with the dashboard on a free port, run ``check`` against it, stop everything."""
    config_path = tmp_path / "machine.yaml"
    config_path.write_text(MACHINE)
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    robot = build_robot(load_config(config_path), transport, data_dir=tmp_path / "data")
    if base is not None:
        robot.components["rosarnl_node"] = base

    async def main() -> None:
        api = RobotAPI(transport.node("cyborg_api"), machine=robot.config.machine)
        register(api, robot)
        url = (await api.start("127.0.0.1", 0)).rstrip("/")
        robot.start()
        async with ClientSession() as session:

            async def fetch(path: str) -> tuple[int, Any]:
                async with session.get(url + path) as response:
                    if response.content_type == "application/json":
                        return response.status, await response.json()
                    return response.status, await response.read()

            try:
                await check(fetch, robot)
            finally:
                await robot.controller.stop()
                await api.stop()

    try:
        clock.run(main())
    finally:
        transport.shutdown()
        clock.close()


def read_png(data: bytes) -> tuple[np.ndarray[Any, Any], list[tuple[int, int, int, int]]]:
    """Decode the indexed PNG that png_bytes writes: (indices top row first, RGBA palette)."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    chunks: dict[bytes, bytes] = {}
    position = 8
    while position < len(data):
        (length,) = struct.unpack(">I", data[position : position + 4])
        kind = data[position + 4 : position + 8]
        body = data[position + 8 : position + 8 + length]
        assert struct.unpack(">I", data[position + 8 + length : position + 12 + length])[0] == zlib.crc32(
            kind + body
        )
        chunks[kind] = chunks.get(kind, b"") + body
        position += 12 + length
    width, height, depth, colour_type = struct.unpack(">IIBB", chunks[b"IHDR"][:10])
    assert (depth, colour_type) == (8, 3)
    rows = np.frombuffer(zlib.decompress(chunks[b"IDAT"]), dtype=np.uint8).reshape(height, width + 1)
    assert not rows[:, 0].any(), "every row uses filter type 0"
    rgb = chunks[b"PLTE"]
    alpha = chunks[b"tRNS"]
    palette = [(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2], alpha[i]) for i in range(len(alpha))]
    return rows[:, 1:], palette


def test_health_reports_the_controller_and_each_module(tmp_path: Path) -> None:
    async def check(fetch: Fetch, robot: Robot) -> None:
        for _ in range(100):
            status, health = await fetch("/api/health")
            if health["active_state"] == "idle" and health["goal_status"] == "ACTIVE":
                break
            await robot.controller.node.clock.sleep(0.02)
        assert status == 200
        assert health["phase"] == "active" and health["active_module"] == "cyborg_idle"
        assert health["stats"]["handovers"] == 1 and "events_invalid" in health["stats"]
        assert health["has_base"] is False and health["emotion_enabled"] is True
        assert 0 <= health["seconds_in_state"] < 5
        modules = {m["name"]: m for m in health["modules"]}
        assert modules["cyborg_idle"]["active"] and modules["cyborg_idle"]["goal_status"] == "ACTIVE"
        assert modules["cyborg_music"] == {
            "name": "cyborg_music",
            "states": ["music"],
            "active": False,
            "goal_status": None,
            "seconds_since_active": None,
        }

    serve(tmp_path, None, check)


def test_without_a_base_the_map_endpoints_say_so_and_how_to_fix_it(tmp_path: Path) -> None:
    async def check(fetch: Fetch, robot: Robot) -> None:
        for path in ("/api/map", "/api/route"):
            status, body = await fetch(path)
            assert status == 404 and body == {"error": NO_BASE, "has_base": False}
        status, text = await fetch("/api/map.png")
        assert status == 404 and b"no simulated base" in text and b"fix:" in text
        assert "simulated_base" in NO_BASE

    serve(tmp_path, None, check)


def test_map_route_and_png_with_a_base(tmp_path: Path) -> None:
    occupancy = small_map()
    base = FakeBase(occupancy, [(0.0, 0.0), (1.0, -0.5)])

    async def check(fetch: Fetch, robot: Robot) -> None:
        status, info = await fetch("/api/map")
        assert status == 200
        assert info["source"] == "small.map" and info["resolution"] == 0.5
        assert info["origin"] == [-1.0, -2.0] and info["cells"] == [6, 4] and info["size_m"] == [3.0, 2.0]
        assert info["locations"] == [
            {"name": "cafeteria", "x": 1.0, "y": -0.5, "theta": 0.0, "kind": "GoalWithHeading"}
        ]
        assert info["keep_out"] == [
            {"name": "stairs", "line": False, "corners": [[0.0, 0.0], [0.5, 0.0], [0.5, 0.5]]}
        ]
        status, png = await fetch(info["image"])
        assert status == 200
        pixels, palette = read_png(png)
        colours = np.array(palette)[pixels]
        assert colours.shape == (4, 6, 4)
        assert (colours[-1] == MAP_COLOURS[Cell.OCCUPIED]).all(), (
            "the southern wall is the image's bottom row"
        )
        assert tuple(colours[0, 5]) == MAP_COLOURS[Cell.UNKNOWN] and MAP_COLOURS[Cell.UNKNOWN][3] == 0
        assert tuple(colours[1, 1]) == MAP_COLOURS[Cell.FREE]

        status, small = await fetch(info["image"] + "?max=16")
        assert status == 200 and read_png(small)[0].shape == (4, 6), "already small enough: not shrunk"
        status, problem = await fetch(info["image"] + "?max=big")
        assert status == 400 and b"whole number" in problem

        status, route = await fetch("/api/route")
        assert status == 200 and route["route"] == [[0.0, 0.0], [1.0, -0.5]] and route["pose"] is None
        assert route["remaining"] == route["route"] and route["path_state"] is None
        base.x, base.y, base.theta = 0.5, -0.25, 0.1  # the base shows its live pose: it wins
        route = (await fetch("/api/route"))[1]
        assert {k: route["pose"][k] for k in ("x", "y", "theta")} == {"x": 0.5, "y": -0.25, "theta": 0.1}
        assert route["remaining"] == [[0.5, -0.25], [1.0, -0.5]]
        base.route = None
        assert (await fetch("/api/route"))[1]["route"] is None
        assert (await fetch("/api/health"))[1]["has_base"] is True

    serve(tmp_path, base, check)


def test_route_points_keeps_the_finite_points() -> None:
    assert route_points(((0, 1), (2.5, 3))) == [[0.0, 1.0], [2.5, 3.0]]
    assert route_points([(1, 2), (float("nan"), 0)]) == [[1.0, 2.0]]
    assert route_points(None) is None


def test_remaining_route_starts_at_the_nearest_point_of_the_nearest_leg() -> None:
    route = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]]
    assert remaining_route(route, (1.0, 0.2)) == [[1.0, 0.0], [4.0, 0.0], [4.0, 4.0]]
    assert remaining_route(route, (4.1, 3.0)) == [[4.0, 3.0], [4.0, 4.0]]
    assert remaining_route(route, (9.0, 9.0)) == [[4.0, 4.0]]
    assert remaining_route([[1.0, 1.0]], (0.0, 0.0)) == [[1.0, 1.0]]


def test_pooled_grid_keeps_thin_walls_and_pads_with_unknown() -> None:
    grid = np.zeros((5, 5), dtype=np.uint8)
    grid[2, :] = Cell.OCCUPIED  # a wall one cell thick
    grid[4, 4] = Cell.UNKNOWN
    pooled = pooled_grid(grid, 2)
    assert pooled.shape == (3, 3)
    assert (pooled[1] == Cell.OCCUPIED).all() and (pooled[0] == Cell.FREE).all()
    assert pooled[2, 2] == Cell.UNKNOWN and pooled[2, 0] == Cell.FREE
    assert pooled_grid(grid, 1) is grid


def test_png_bytes_refuses_values_outside_the_palette() -> None:
    with pytest.raises(ValueError, match="palette has 1 colours"):
        png_bytes(np.array([[0, 1]], dtype=np.uint8), [(0, 0, 0, 255)])
    with pytest.raises(ValueError, match="non-empty 2-D"):
        png_bytes(np.zeros((0, 3), dtype=np.uint8), [(0, 0, 0, 255)])


def test_health_shows_the_motivator_rule_and_feedback_ages_where_known(tmp_path: Path) -> None:
    async def check(fetch: Fetch, robot: Robot) -> None:
        health = (await fetch("/api/health"))[1]
        settings = robot.config.model.motivator
        assert health["motivator"] == {
            "selection": settings.selection.value,
            "rate_seconds": settings.rate_seconds,
        }
        modules = {m["name"]: m for m in health["modules"]}
        assert "seconds_since_feedback" not in modules["cyborg_music"], "never ran: no field"
        # The running module's goal sends a heartbeat, which the controller notes.
        assert 0.0 <= modules["cyborg_idle"]["seconds_since_feedback"] <= HEARTBEAT_SECONDS

        now = robot.controller.node.clock.now()
        # As the controller may report it (by module or by action name) ...
        robot.controller.last_feedback_at = {"cyborg_idle": now - 3.0, "/cyborg_music/play": now - 40.0}
        modules = {m["name"]: m for m in (await fetch("/api/health"))[1]["modules"]}
        assert 3.0 <= modules["cyborg_idle"]["seconds_since_feedback"] < 4.0
        assert modules["cyborg_idle"]["last_feedback_at"] == pytest.approx(now - 3.0, abs=1e-3)
        assert 40.0 <= modules["cyborg_music"]["seconds_since_feedback"] < 41.0

    serve(tmp_path, None, check)


def test_under_ros_the_emotion_switch_is_read_from_the_emotion_systems_parameter(tmp_path: Path) -> None:
    """`cyborg node cyborg_api` has no emotion system in process: it reads the switch the emotion
    system keeps in the parameter /cyborg_controller/emotion_enabled (another node's, as under ROS)."""
    config_path = tmp_path / "machine.yaml"
    config_path.write_text(MACHINE)
    config = load_config(config_path)
    clock = RealClock()
    transport = EmbeddedTransport(clock)

    async def main() -> None:
        node = transport.node("cyborg_api")
        api = RobotAPI(node, machine=config.machine)
        register(api, remote_robot(node, config, None))
        url = (await api.start("127.0.0.1", 0)).rstrip("/")
        switch = transport.node("rostopic_pub").publisher(topics.EMOTIONAL_CONTROLLER, String)
        try:
            async with ClientSession() as session:

                async def enabled(expected: bool | None) -> None:
                    for _ in range(100):
                        async with session.get(url + "/api/health") as response:
                            health = await response.json()
                        if health["emotion_enabled"] is expected:
                            return
                        await clock.sleep(0.02)
                    raise AssertionError(f"emotion_enabled is {health['emotion_enabled']}, not {expected}")

                await enabled(None)  # no emotion system has started: not known
                EmotionSystem(transport.node("cyborg_controller"), EmotionSettings())
                await enabled(True)  # a fresh start is on
                switch.publish(String(data="off"))
                await enabled(False)
                switch.publish(String(data="louder"))  # not a switch: the emotion system ignores it too
                await clock.sleep(0.1)
                await enabled(False)
                async with session.post(url + "/api/emotion/switch", json={"on": True}) as response:
                    assert response.status == 200
                await enabled(True)  # the API's own command counts as well
        finally:
            await api.stop()

    try:
        clock.run(main())
    finally:
        transport.shutdown()
        clock.close()
