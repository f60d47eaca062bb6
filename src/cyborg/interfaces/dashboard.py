"""The live browser dashboard a running robot serves at ``/`` (thesis 2.3.3, 2.7, 8.1.4).

One page in the spirit of SMACH Viewer, the command tool and MobileEyes: the
state machine with its active state, each module's health, the emotion, the
map with the robot's pose and route, the event log and controls. The page is
plain HTML/JS/CSS from :file:`static/` (no build step, nothing fetched from the
internet); it reads the API's websocket and the JSON endpoints added here:
``/api/health``, ``/api/map`` (+ ``/api/map.png``) and ``/api/route``.
Register it with :func:`register` (``cyborg.interfaces.serve.EXTENSIONS`` does).
"""

from __future__ import annotations

import dataclasses
import math
import struct
import zlib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from aiohttp import web
from numpy.typing import NDArray

from cyborg.interfaces.api import RobotAPI
from cyborg.sim.maps import Cell, OccupancyMap
from cyborg.sim.robot import Robot

STATIC_DIR = Path(__file__).resolve().parent / "static"
BASE_NODE = "rosarnl_node"
NO_BASE = (
    f"this robot has no simulated base (no {BASE_NODE!r} module with a map); "
    f"fix: add `{BASE_NODE}: {{kind: simulated_base}}` under modules: in the YAML and run `cyborg sim --map FILE`"
)

# Colours of the occupancy grid image, RGBA: free floor, walls, unknown space (transparent).
MAP_COLOURS: dict[Cell, tuple[int, int, int, int]] = {
    Cell.FREE: (236, 239, 244, 255),
    Cell.OCCUPIED: (40, 44, 52, 255),
    Cell.UNKNOWN: (0, 0, 0, 0),
}


def png_bytes(grid: NDArray[np.uint8], palette: Sequence[tuple[int, int, int, int]]) -> bytes:
    """Encode a 2-D array of palette indices (top row first) as an indexed-colour PNG."""
    if grid.ndim != 2 or grid.size == 0:
        raise ValueError(f"png_bytes needs a non-empty 2-D array, got shape {grid.shape}")
    if not 0 < len(palette) <= 256 or int(grid.max()) >= len(palette):
        raise ValueError(f"grid values reach {int(grid.max())} but the palette has {len(palette)} colours")
    height, width = grid.shape
    rows = np.zeros((height, width + 1), dtype=np.uint8)  # a filter-type byte (0: none) before each row
    rows[:, 1:] = grid

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return b"".join(
        [
            b"\x89PNG\r\n\x1a\n",
            chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 3, 0, 0, 0)),
            chunk(b"PLTE", bytes(c for rgba in palette for c in rgba[:3])),
            chunk(b"tRNS", bytes(rgba[3] for rgba in palette)),
            chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)),
            chunk(b"IEND", b""),
        ]
    )


def map_png(occupancy: OccupancyMap) -> bytes:
    """The occupancy grid as a PNG, north (largest y) up: image row 0 is the grid's last row."""
    order = [Cell.FREE, Cell.OCCUPIED, Cell.UNKNOWN]
    index = np.zeros(256, dtype=np.uint8)
    for i, cell in enumerate(order):
        index[int(cell)] = i
    index[max(order) + 1 :] = order.index(Cell.UNKNOWN)  # anything unexpected shows as unknown
    return png_bytes(index[occupancy.grid[::-1]], [MAP_COLOURS[cell] for cell in order])


def _finite(value: Any) -> float | None:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return round(number, 3) if math.isfinite(number) else None


def route_points(route: Any) -> list[list[float]] | None:
    """A route as ``[[x, y], ...]``: accepts a list of (x, y) pairs or an object with ``waypoints``."""
    if route is None:
        return None
    waypoints: Iterable[Any] = getattr(route, "waypoints", route)
    points: list[list[float]] = []
    try:
        for point in waypoints:
            x, y = _finite(point[0]), _finite(point[1])
            if x is not None and y is not None:
                points.append([x, y])
    except (TypeError, IndexError, KeyError):
        return None
    return points


class Dashboard:
    """The dashboard's routes for one robot and its API."""

    def __init__(self, api: RobotAPI, robot: Robot) -> None:
        self.api = api
        self.robot = robot
        self.clock = robot.controller.node.clock
        self.state_since = self.clock.monotonic()
        self.left_at: dict[str, float] = {}  # module name -> when one of its states was last left
        self._png: tuple[OccupancyMap, bytes] | None = None
        self._module_of = self._modules_by_action()
        robot.controller.add_state_listener(self._on_state_change)

    def routes(self) -> list[web.AbstractRouteDef]:
        return [
            web.get("/", self.index),
            web.get("/dashboard", self.index),
            web.get("/api/health", self.health),
            web.get("/api/map", self.map_info),
            web.get("/api/map.png", self.map_image),
            web.get("/api/route", self.route),
            web.static("/static", STATIC_DIR, append_version=False),
        ]

    # --- bookkeeping ----------------------------------------------------------------------

    def _modules_by_action(self) -> dict[str, str]:
        found: dict[str, str] = {}
        for name, component in self.robot.components.items():
            for action in getattr(component, "servers", {}) or {}:
                found[str(action).lstrip("/")] = name
        return found

    def _module_of_state(self, state: str | None) -> str | None:
        if not state or state not in self.robot.config.machine.states:
            return None
        action = self.robot.config.machine.states[state].action
        return self._module_of.get(action.lstrip("/")) if action else None

    def _on_state_change(self, change: Any) -> None:
        now = self.clock.monotonic()
        left = self._module_of_state(getattr(change, "from_system_state", None))
        if left is not None:
            self.left_at[left] = now
        self.state_since = now

    def _base(self) -> Any:
        """The simulated base component, if this robot has one."""
        base = self.robot.components.get(BASE_NODE)
        if base is not None:
            return base
        for component in self.robot.components.values():
            if isinstance(getattr(component, "map", None), OccupancyMap):
                return component
        return None

    def _map(self) -> OccupancyMap | None:
        occupancy = getattr(self._base(), "map", None)
        return occupancy if isinstance(occupancy, OccupancyMap) else None

    def _robot_time(self) -> float:
        """Seconds since the API's record stream started: the ``t`` of records."""
        return round(self.api.stream.now(), 3)

    # --- handlers -------------------------------------------------------------------------

    async def index(self, request: web.Request) -> web.FileResponse:
        page = STATIC_DIR / "index.html"
        if not page.is_file():
            raise web.HTTPNotFound(
                text=f"the dashboard page {page} is missing; fix: reinstall the package (pip install -e .)"
            )
        return web.FileResponse(page, headers={"Cache-Control": "no-cache"})

    async def health(self, request: web.Request) -> web.Response:
        controller = self.robot.controller
        now = self.clock.monotonic()
        active_module = self._module_of_state(controller.active_state)
        goal = controller.goal_status
        modules = []
        for name, component in self.robot.components.items():
            servers = sorted(str(action).lstrip("/") for action in getattr(component, "servers", {}) or {})
            states = [
                st.name
                for st in self.robot.config.machine.states.values()
                if st.action and st.action.lstrip("/") in servers
            ]
            active = name == active_module
            left = self.left_at.get(name)
            modules.append(
                {
                    "name": name,
                    "states": states,
                    "active": active,
                    "goal_status": goal.name if active and goal is not None else None,
                    "seconds_since_active": 0.0
                    if active
                    else (round(now - left, 1) if left is not None else None),
                }
            )
        return web.json_response(
            {
                "t": self._robot_time(),
                "time": self.clock.now(),
                "active_state": controller.active_state,
                "previous_state": controller.previous_state or None,
                "last_event": controller.last_event or None,
                "phase": controller.phase.value,
                "goal_status": goal.name if goal is not None else None,
                "active_module": active_module,
                "seconds_in_state": round(now - self.state_since, 2),
                "stats": dataclasses.asdict(controller.stats),
                "emotion_enabled": bool(getattr(self.robot.emotion, "enabled", True)),
                "has_base": self._map() is not None,
                "modules": modules,
            }
        )

    async def map_info(self, request: web.Request) -> web.Response:
        occupancy = self._map()
        if occupancy is None:
            return web.json_response({"error": NO_BASE, "has_base": False}, status=404)
        rows, cols = occupancy.shape
        width, height = occupancy.size_m
        return web.json_response(
            {
                "has_base": True,
                "source": Path(occupancy.source).name if occupancy.source else "",
                "resolution": occupancy.resolution,
                "origin": list(occupancy.origin),
                "cells": [cols, rows],
                "size_m": [round(width, 3), round(height, 3)],
                "image": "/api/map.png",
                "locations": [
                    {"name": p.name, "x": p.x, "y": p.y, "theta": p.theta, "kind": p.kind}
                    for p in occupancy.poses
                ],
                "keep_out": [
                    {"name": zone.name, "line": zone.is_line, "corners": [list(c) for c in zone.corners]}
                    for zone in occupancy.keep_out
                ],
            }
        )

    async def map_image(self, request: web.Request) -> web.Response:
        occupancy = self._map()
        if occupancy is None:
            raise web.HTTPNotFound(text=NO_BASE)
        if self._png is None or self._png[0] is not occupancy:
            self._png = (occupancy, map_png(occupancy))
        return web.Response(body=self._png[1], content_type="image/png")

    async def route(self, request: web.Request) -> web.Response:
        base = self._base()
        if self._map() is None:
            return web.json_response({"error": NO_BASE, "has_base": False}, status=404)
        pose = next((r for r in reversed(self.api.records) if r["type"] == "pose"), None)
        return web.json_response(
            {
                "has_base": True,
                "t": self._robot_time(),
                "route": route_points(getattr(base, "route", None)),
                "pose": {k: pose[k] for k in ("t", "x", "y", "theta")} if pose else None,
            }
        )


def register(api: RobotAPI, robot: Robot) -> None:
    """Add the dashboard's page, static files and endpoints to ``api`` (an entry of serve.EXTENSIONS)."""
    api.app.add_routes(Dashboard(api, robot).routes())
