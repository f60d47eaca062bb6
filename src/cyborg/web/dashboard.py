"""The live browser dashboard a running robot serves at ``/`` (thesis 2.3.3, 2.7, 8.1.4).

One page in the spirit of SMACH Viewer, the command tool and MobileEyes: the
state machine with its active state, each module's health, the emotion, the
map with the robot's pose and route, the event log and controls. The page is
plain HTML/JS/CSS from :file:`static/` (no build step, nothing fetched from the
internet; pan and zoom come from the vendored svg-pan-zoom, BSD-2-Clause); it reads the API's websocket and the JSON endpoints added here:
``/api/health``, ``/api/map`` (+ ``/api/map.png``) and ``/api/route``.
Register it with :func:`register` (``cyborg.web.build.EXTENSIONS`` does).
"""

from __future__ import annotations

import asyncio
import dataclasses
import itertools
import json
import math
import struct
import zlib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from aiohttp import web
from numpy.typing import NDArray

from cyborg.app.view import BaseStatus, RobotView
from cyborg.controller.regions import Lanes, Regions
from cyborg.errors import InvalidValueError
from cyborg.maps import Cell, OccupancyMap
from cyborg.transport.messages import SystemState
from cyborg.web.api import RobotAPI

STATIC_DIR = Path(__file__).resolve().parent / "static"
BASE_NODE = "rosarnl_node"
NO_BASE = (
    f"this robot has no simulated base (no {BASE_NODE!r} module with a map); "
    f"fix: add `{BASE_NODE}: {{kind: simulated_base}}` under modules: in the YAML "
    "(it drives on Glassgården if its map is found, else the example campus, unless you pass `cyborg sim --map FILE`)"
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
        raise InvalidValueError(f"png_bytes needs a non-empty 2-D array, got shape {grid.shape}")
    if not 0 < len(palette) <= 256 or int(grid.max()) >= len(palette):
        raise InvalidValueError(
            f"grid values reach {int(grid.max())} but the palette has {len(palette)} colours"
        )
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


def pooled_grid(grid: NDArray[np.uint8], factor: int) -> NDArray[np.uint8]:
    """Shrink ``grid`` by ``factor`` in both directions, keeping thin walls: a block is OCCUPIED if
    any of its cells is, else FREE if any is, else UNKNOWN. Edges are padded with UNKNOWN cells."""
    if factor <= 1:
        return grid
    rows, cols = grid.shape
    padded = np.full((-(-rows // factor) * factor, -(-cols // factor) * factor), Cell.UNKNOWN, dtype=np.uint8)
    padded[:rows, :cols] = grid
    blocks = padded.reshape(padded.shape[0] // factor, factor, padded.shape[1] // factor, factor)
    occupied = (blocks == Cell.OCCUPIED).any(axis=(1, 3))
    free = (blocks == Cell.FREE).any(axis=(1, 3))
    pooled = np.full(occupied.shape, Cell.UNKNOWN, dtype=np.uint8)
    pooled[free] = Cell.FREE
    pooled[occupied] = Cell.OCCUPIED
    return pooled


def map_png(occupancy: OccupancyMap, factor: int = 1) -> bytes:
    """The occupancy grid as a PNG, north (largest y) up: image row 0 is the grid's last row.

    With ``factor`` > 1 each pixel covers factor x factor cells (see :func:`pooled_grid`); the
    image's lower-left corner stays at the map's origin.
    """
    order = [Cell.FREE, Cell.OCCUPIED, Cell.UNKNOWN]
    index = np.zeros(256, dtype=np.uint8)
    index[:] = order.index(Cell.UNKNOWN)  # anything unexpected shows as unknown
    for i, cell in enumerate(order):
        index[int(cell)] = i
    grid = pooled_grid(occupancy.grid, factor)
    return png_bytes(index[grid[::-1]], [MAP_COLOURS[cell] for cell in order])


def _finite(value: Any) -> float | None:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return round(number, 3) if math.isfinite(number) else None


def route_points(route: Iterable[Sequence[float]] | None) -> list[list[float]] | None:
    """A route as ``[[x, y], ...]`` (points that are not finite are left out)."""
    if route is None:
        return None
    points: list[list[float]] = []
    for point in route:
        x, y = _finite(point[0]), _finite(point[1])
        if x is not None and y is not None:
            points.append([x, y])
    return points


class Dashboard:
    """The dashboard's routes for one robot and its API."""

    def __init__(self, api: RobotAPI, robot: RobotView) -> None:
        self.api = api
        self.robot = robot
        self.clock = robot.controller.node.clock
        self.state_since = self.clock.monotonic()
        self.left_at: dict[str, float] = {}  # module name -> when one of its states was last left
        self._png: dict[tuple[OccupancyMap, int], bytes] = {}  # (map, cells per pixel) -> PNG
        self._module_of = self._modules_by_action()
        self._module_states = self._states_of_modules()
        self._feedback_keys: dict[str, dict[str, int]] = {}  # module -> key the controller may use -> rank
        self._states_text: dict[str, str] = {}  # module -> its states as JSON
        self._lanes = Lanes(Regions(robot.config.machine))  # one lane per region of a parallel state
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
        return {action: name for name, actions in self.robot.module_actions().items() for action in actions}

    def _states_of_modules(self) -> dict[str, tuple[list[str], list[str]]]:
        """Per module: its servers and the states whose action they serve, in the machine's order.
        Worked out once (the machine and the modules stay as built): /api/health, polled every
        second, then costs what the modules' entries do, not modules x states."""
        by_action: dict[str, list[str]] = {}
        for st in self.robot.config.machine.states.values():
            if st.action:
                by_action.setdefault(st.action.lstrip("/"), []).append(st.name)
        order = {name: index for index, name in enumerate(self.robot.config.machine.states)}
        table: dict[str, tuple[list[str], list[str]]] = {}
        for name, actions in self.robot.module_actions().items():
            servers = sorted(actions)
            states = {state for server in set(servers) for state in by_action.get(server, ())}
            table[name] = (servers, sorted(states, key=order.__getitem__))
        return table

    def _module_of_state(self, state: str | None) -> str | None:
        if not state or state not in self.robot.config.machine.states:
            return None
        action = self.robot.config.machine.states[state].action
        return self._module_of.get(action.lstrip("/")) if action else None

    def _on_state_change(self, change: SystemState) -> None:
        now = self.clock.monotonic()
        left = self._module_of_state(change.from_system_state)
        if left is not None:
            self.left_at[left] = now
        self.state_since = now
        self._lanes.on_change(change.to_system_state, now)

    def _map(self) -> OccupancyMap | None:
        base = self.robot.base()
        return base.map if base is not None else None

    def _storage(self) -> dict[str, Any] | None:
        """Whether the robot's data is being saved (see storage.SaveStatus); None where not known."""
        status = self.robot.save_status()
        return status.as_json() if status is not None else None

    def _motivator_settings(self) -> dict[str, Any]:
        """The configured selection rule and rate, which the page shows with the motivator's decisions."""
        settings = self.robot.config.model.motivator
        return {"selection": settings.selection.value, "rate_seconds": _finite(settings.rate_seconds)}

    def _last_feedback_at(self, name: str, servers: Sequence[str]) -> float | None:
        """When module ``name`` last sent feedback, in clock seconds (``clock.now()``), if the controller
        says (by module name or action name); None if it does not."""
        known = self.robot.controller.last_feedback_at
        rank = self._feedback_keys.get(name)
        if rank is None:  # once per module: its names in the order they count
            keys = (name, *servers, *(f"/{server}" for server in servers))
            rank = self._feedback_keys[name] = {key: index for index, key in reversed(list(enumerate(keys)))}
        found = [
            (rank[key], value) for key, value in known.items() if key in rank and _finite(value) is not None
        ]
        return _finite(min(found)[1]) if found else None  # O(modules that reported), not O(states)

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
        """The controller, each module, the emotion switch and the motivator's rule, for the page.

        ``emotion_enabled`` is null where it is not known (under ROS before any on/off was seen);
        so is ``storage`` (whether the controller's data is saved, and if not why) under ROS;
        a module has ``last_feedback_at`` / ``seconds_since_feedback`` only where something reports it.
        """
        controller = self.robot.controller
        now = self.clock.monotonic()
        active_module = self._module_of_state(controller.active_state)
        lanes = self._lanes.report(now)
        in_control = {self._module_of_state(str(lane["state"])) for lane in lanes} | {active_module}
        goal = controller.goal_status
        modules = []
        for name, (servers, states) in self._module_states.items():
            active = name in in_control
            left = self.left_at.get(name)
            module: dict[str, Any] = {
                "name": name,
                "active": active,
                "goal_status": goal.name if active and goal is not None else None,
                "seconds_since_active": 0.0
                if active
                else (round(now - left, 1) if left is not None else None),
            }
            feedback_at = self._last_feedback_at(name, servers)
            if feedback_at is not None:
                module["last_feedback_at"] = feedback_at
                module["seconds_since_feedback"] = round(max(0.0, self.clock.now() - feedback_at), 1)
            # the states, which never change, as JSON made once: a machine's size costs a copy
            modules.append(f'{json.dumps(module)[:-1]}, "states": {self._states_json(name, states)}}}')
        body = json.dumps(
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
                "regions": lanes,
                "emotion_enabled": self.robot.emotion_enabled(),
                "storage": self._storage(),
                "motivator": self._motivator_settings(),
                "has_base": self._map() is not None,
            }
        )
        return web.Response(
            text=f'{body[:-1]}, "modules": [{", ".join(modules)}]}}', content_type="application/json"
        )

    def _states_json(self, module: str, states: list[str]) -> str:
        text = self._states_text.get(module)
        if text is None:
            text = self._states_text[module] = json.dumps(states)
        return text

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
        """The grid as a PNG; ``?max=N`` shrinks it to at most N pixels a side (walls kept)."""
        occupancy = self._map()
        if occupancy is None:
            raise web.HTTPNotFound(text=NO_BASE)
        factor = 1
        if "max" in request.query:
            try:
                limit = int(request.query["max"])
            except ValueError:
                raise web.HTTPBadRequest(
                    text="'max' must be a whole number of pixels, e.g. ?max=800"
                ) from None
            if limit < 16:
                raise web.HTTPBadRequest(text=f"'max' must be at least 16 pixels, got {limit}")
            factor = max(1, math.ceil(max(occupancy.shape) / limit))
        key = (occupancy, factor)
        if key not in self._png:
            if len(self._png) > 8:
                self._png.clear()
            loop = asyncio.get_running_loop()
            self._png[key] = await loop.run_in_executor(None, map_png, occupancy, factor)
        return web.Response(
            body=self._png[key],
            content_type="image/png",
            headers={"X-Cells-Per-Pixel": str(factor), "Cache-Control": "no-cache"},
        )

    async def route(self, request: web.Request) -> web.Response:
        base = self.robot.base()
        if base is None:
            return web.json_response({"error": NO_BASE, "has_base": False}, status=404)
        status = base.status()
        pose = self._pose(status)
        planned = route_points(status.route)
        return web.json_response(
            {
                "has_base": True,
                "t": self._robot_time(),
                "pose": pose,
                "route": planned,
                "remaining": remaining_route(planned, (pose["x"], pose["y"]))
                if planned and pose
                else planned,
                "path_state": status.path_state,
                "wandering": status.wandering,
                "distance_travelled": _finite(status.distance_travelled),
            }
        )

    def _pose(self, status: BaseStatus) -> dict[str, float] | None:
        """The base's live pose if it shows one, else the last pose record (those come at most 1/s)."""
        if status.has_pose:
            assert status.x is not None and status.y is not None and status.theta is not None
            return {"t": self._robot_time(), "x": status.x, "y": status.y, "theta": status.theta}
        record = next((r for r in reversed(self.api.records) if r["type"] == "pose"), None)
        return {k: record[k] for k in ("t", "x", "y", "theta")} if record else None


def remaining_route(route: list[list[float]], position: tuple[float, float]) -> list[list[float]]:
    """The part of ``route`` still ahead of ``position``: from there on along the nearest leg."""
    if len(route) < 2:
        return route
    best, best_index, best_point = math.inf, 0, list(position)
    for index, (a, b) in enumerate(itertools.pairwise(route)):
        dx, dy = b[0] - a[0], b[1] - a[1]
        length2 = dx * dx + dy * dy
        u = 0.0 if length2 == 0 else ((position[0] - a[0]) * dx + (position[1] - a[1]) * dy) / length2
        u = min(1.0, max(0.0, u))
        point = [a[0] + u * dx, a[1] + u * dy]
        distance = math.dist(point, position)
        if distance < best - 1e-9:
            best, best_index, best_point = distance, index, point
    ahead = [[round(best_point[0], 3), round(best_point[1], 3)], *route[best_index + 1 :]]
    return ahead[1:] if len(ahead) > 1 and ahead[0] == ahead[1] else ahead


def register(api: RobotAPI, robot: RobotView) -> None:
    """Add the dashboard's page, static files and endpoints to ``api`` (an entry of serve.EXTENSIONS)."""
    api.app.add_routes(Dashboard(api, robot).routes())
