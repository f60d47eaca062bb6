"""``cyborg replay``: the dashboard on a recording, at any moment of it.

Serves :file:`static/replay.html` (a time slider, play/pause and speed; at the slider's moment the
active state and last transition, the emotion and its plot, the robot's track on the map and the
log up to then, the map behind the track) and a read-only API that answers as the robot's would have at that moment:
``GET /api/status?at=SECONDS`` (seconds since the recording started), ``GET /api/records?at=``
and ``GET /api/replay`` (what the recording is: its span, metadata and marks). The recording is
read once; a moment is then a binary search per record type.
"""

from __future__ import annotations

import asyncio
import bisect
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aiohttp import web

from cyborg.errors import CyborgError, InvalidValueError
from cyborg.observe.recording import Glance, Recording, glance, open_recording, recorded_map, window
from cyborg.observe.records import NS_PER_S, Record

if TYPE_CHECKING:
    from cyborg.controller.machine import MachineSpec
    from cyborg.maps import OccupancyMap

__all__ = ["ReplayAPI", "ReplayView", "serve_replay"]

RECORDS_SHOWN = 200
"""The log's records up to a moment that ``/api/records`` gives (the latest)."""
STATIC_DIR = Path(__file__).resolve().parent / "static"
"""The pages (the same folder as the live dashboard's; not imported from it, to start quicker)."""
EARLY_SECONDS = 60.0
"""While the recording is read, a moment up to this far in is answered from a window of it."""
GRAPH_TIMEOUT = 10.0
"""Real seconds Graphviz may take to lay out the recorded machine."""
GRAPH_MEMORY = 2**30
MAP_PIXELS = 720
"""The map image is at most about this many pixels a side (walls kept)."""
TRACK_POINTS = 4000
"""At most about this many points of the robot's track and the emotion plot go to the page."""


class _Timeline:
    """Records of one type, searchable by time."""

    def __init__(self, records: Sequence[Record]) -> None:
        self.records = list(records)
        self.times = [int(r["t_ns"]) for r in self.records]

    def last(self, t_ns: int) -> Record | None:
        index = bisect.bisect_right(self.times, t_ns)
        return self.records[index - 1] if index else None

    def upto(self, t_ns: int) -> list[Record]:
        return self.records[: bisect.bisect_right(self.times, t_ns)]


class ReplayView:
    """One recording as the replay page sees it: what it is, and any moment of it.

    ``begin_ns``: where the page's slider starts (the live dashboard's look back shows only the
    last minutes of a recording); the state, emotion and pose at a moment still come from
    everything recorded before it.
    """

    def __init__(self, recording: Recording, *, begin_ns: int = 0, live: bool = False) -> None:
        self.recording = recording
        marked = [int(m["t_ns"]) for m in recording.marks]
        self.end_ns = max([recording.end_ns, *marked])
        """The last moment recorded (a record, or a mark after the last record)."""
        self.begin_ns = max(0, min(begin_ns, self.end_ns))
        self.live = live
        by_type: dict[str, list[Record]] = {}
        for record in recording.records:
            by_type.setdefault(str(record["type"]), []).append(record)
        self.timelines = {kind: _Timeline(records) for kind, records in by_type.items()}
        self.all = _Timeline(recording.records)

    def at(self, raw: str | None) -> int:
        """The moment ``?at=`` names (seconds since the recording started); its end if none."""
        if raw is None:
            return self.end_ns
        try:
            seconds = float(raw)
        except ValueError:
            seconds = math.nan
        if not math.isfinite(seconds) or seconds < 0:
            raise web.HTTPBadRequest(
                text=f"'at' must be seconds since the recording started (0 to "
                f"{self.end_ns / NS_PER_S:g}), got {raw[:40]!r}"
            )
        return round(seconds * NS_PER_S)

    def status_at(self, t_ns: int) -> dict[str, Any]:
        """What ``/api/status`` of the robot would have answered ``t_ns`` after the start."""
        state = self._last("state", t_ns)
        emotion = self._last("emotion", t_ns)
        pose = self._last("pose", t_ns)
        decision = self._last("motivator", t_ns)
        return {
            "at": round(t_ns / NS_PER_S, 3),
            "time": (self.recording.start_ns + t_ns) / NS_PER_S,
            "state": state["to"] if state else None,
            "previous_state": (state["from"] or None) if state else None,
            "event": state["event"] if state else None,
            "since": state["t"] if state else None,
            "emotion": emotion["emotion"] if emotion else "neutral",
            "pleasure": emotion["pleasure"] if emotion else 0.0,
            "arousal": emotion["arousal"] if emotion else 0.0,
            "dominance": emotion["dominance"] if emotion else 0.0,
            "pose": {k: pose[k] for k in ("t", "x", "y", "theta")} if pose else None,
            "last_decision": {k: decision.get(k) for k in ("t", "event", "reason")} if decision else None,
        }

    def _last(self, kind: str, t_ns: int) -> Record | None:
        timeline = self.timelines.get(kind)
        return timeline.last(t_ns) if timeline is not None else None

    def records_at(self, t_ns: int) -> list[Record]:
        """The latest records up to ``t_ns`` (at most RECORDS_SHOWN), oldest first."""
        index = bisect.bisect_right(self.all.times, t_ns)
        return self.all.records[max(0, index - RECORDS_SHOWN) : index]

    def _shown(self, kind: str) -> list[Record]:
        timeline = self.timelines.get(kind)
        if timeline is None:
            return []
        first = bisect.bisect_left(timeline.times, self.begin_ns)
        return timeline.records[max(0, first - 1) :]

    def info(self) -> dict[str, Any]:
        """What the recording is: its span, metadata, marks, the robot's track and the emotion plot."""
        recording = self.recording
        poses = self._shown("pose")
        every = max(1, len(poses) // TRACK_POINTS)
        emotions = self._shown("emotion")
        step = max(1, len(emotions) // TRACK_POINTS)
        return {
            "file": recording.path.name,
            "begin": self.begin_ns / NS_PER_S,
            "duration": self.end_ns / NS_PER_S,
            "live": self.live,
            "records": len(recording.records),
            "metadata": recording.metadata,
            "marks": [
                {"t": m["t_ns"] / NS_PER_S, "note": m.get("note")}
                for m in recording.marks
                if m["t_ns"] >= self.begin_ns
            ],
            "problem": None if self.live else recording.problem,
            "track": [[r["t"], r["x"], r["y"]] for r in poses[::every]],
            "emotions": [[r["t"], r["pleasure"], r["arousal"], r["dominance"]] for r in emotions[::step]],
        }


class ReplayAPI:
    """The read-only API of one recording (see the module docstring).

    Given a :class:`~cyborg.observe.recording.Recording`, it answers from it. Given only a
    :class:`~cyborg.observe.recording.Glance` (:meth:`of_file`), it is served at once: until the
    recording is read, ``/api/replay`` says ``loading`` (its span and metadata, no track or plot
    yet) and a moment within the first EARLY_SECONDS is answered from a window read through the
    file's index, so that the page shows its start without waiting. The whole read (:meth:`load`,
    on a worker thread) starts when first needed: ``/api/replay?wait=1`` (the page asks once it
    shows the start), a later moment or the map; those wait for it.
    """

    def __init__(self, recording: Recording | None = None, *, glance: Glance | None = None) -> None:
        if recording is None and glance is None:
            raise InvalidValueError(
                "ReplayAPI needs a recording or a glance at one; fix: give recording= or glance="
            )
        self.glance = glance
        self.view = ReplayView(recording) if recording is not None else None
        self.recording = recording
        self._loaded: asyncio.Future[None] | None = None
        self._early: dict[int, ReplayView] = {}
        self._map: OccupancyMap | None = None
        self._map_read = False
        self._png: bytes | None = None
        self._drawing: asyncio.Future[tuple[bytes, dict[str, Any]]] | None = None
        self.app = web.Application()
        self.app.add_routes(
            [
                web.get("/", self.index),
                web.get("/api/replay", self.get_replay),
                web.get("/api/status", self.get_status),
                web.get("/api/records", self.get_records),
                web.get("/api/map", self.get_map),
                web.get("/api/map.png", self.get_map_image),
                web.get("/api/machine", self.get_machine),
                web.get("/api/graph.svg", self.get_graph),
                web.get("/api/graph.json", self.get_graph_arrows),
                web.static("/static", STATIC_DIR),
            ]
        )

    @classmethod
    def of_file(cls, path: Path) -> ReplayAPI:
        """The API of the recording at ``path``, checked now and read once served (a file cut short,
        which has no summary, is read whole now)."""
        seen = glance(path)
        return cls(open_recording(path)) if seen is None else cls(glance=seen)

    def load(self) -> asyncio.Future[None]:
        """Read the recording whole on a worker thread (once); the future is done when it is read."""
        if self._loaded is None:
            self._loaded = asyncio.get_running_loop().create_future()
            if self.view is not None:
                self._loaded.set_result(None)
            else:
                assert self.glance is not None
                reading = asyncio.get_running_loop().run_in_executor(None, open_recording, self.glance.path)
                reading.add_done_callback(self._read)
        return self._loaded

    def _read(self, reading: asyncio.Future[Recording]) -> None:
        assert self._loaded is not None
        if reading.cancelled():
            self._loaded.cancel()
            return
        failure = reading.exception()
        if failure is not None:
            self._loaded.set_exception(failure)
            return
        self.recording = reading.result()
        self.view = ReplayView(self.recording)
        self._early.clear()
        self._loaded.set_result(None)

    async def _view(self, t_ns: int | None = None) -> ReplayView:
        """The view to answer from: the whole recording, or early on a window up to ``t_ns``."""
        if self.view is not None:
            return self.view
        if t_ns is not None and t_ns <= EARLY_SECONDS * NS_PER_S:
            return await self._early_view(t_ns)
        await self.load()
        assert self.view is not None
        return self.view

    async def _early_view(self, t_ns: int) -> ReplayView:
        assert self.glance is not None
        glanced = self.glance
        found = self._early.get(t_ns)
        if found is None:
            records = await asyncio.get_running_loop().run_in_executor(None, window, glanced.path, 0, t_ns)
            part = Recording(glanced.path, glanced.metadata, {}, records, [])
            found = self._early[t_ns] = ReplayView(part)
        return found

    def status_at(self, t_ns: int) -> dict[str, Any]:
        """What ``/api/status`` of the robot would have answered ``t_ns`` after the start."""
        assert self.view is not None, "read the recording first (load())"
        return self.view.status_at(t_ns)

    def _at(self, request: web.Request) -> int:
        view = self.view
        if view is None:
            assert self.glance is not None
            view = ReplayView(Recording(self.glance.path, self.glance.metadata, {}, [], []))
            if request.query.get("at") is None:
                return self.glance.end_ns
        return view.at(request.query.get("at"))

    async def index(self, request: web.Request) -> web.FileResponse:
        return web.FileResponse(STATIC_DIR / "replay.html")

    async def get_replay(self, request: web.Request) -> web.Response:
        if self.view is None and request.query.get("wait"):
            await self.load()
        if self.view is not None:
            return web.json_response({**self.view.info(), "loading": False})
        assert self.glance is not None
        glanced = self.glance
        return web.json_response(
            {
                "file": glanced.path.name,
                "begin": 0.0,
                "duration": glanced.end_ns / NS_PER_S,
                "live": False,
                "records": None,
                "metadata": glanced.metadata,
                "marks": [],
                "problem": None,
                "track": [],
                "emotions": [],
                "loading": True,
            }
        )

    async def get_status(self, request: web.Request) -> web.Response:
        t_ns = self._at(request)
        return web.json_response((await self._view(t_ns)).status_at(t_ns))

    async def get_records(self, request: web.Request) -> web.Response:
        t_ns = self._at(request)
        return web.json_response((await self._view(t_ns)).records_at(t_ns))

    async def occupancy(self) -> OccupancyMap | None:
        """The recording's map (decoded once), or None."""
        if not self._map_read:
            await self._view()
            assert self.recording is not None
            self._map, self._map_read = recorded_map(self.recording), True
        return self._map

    async def get_map(self, request: web.Request) -> web.Response:
        """The map the robot ran on, as the live dashboard's ``/api/map`` gives it (404: none recorded)."""
        occupancy = await self.occupancy()
        if occupancy is None:
            return web.json_response({"error": "this recording holds no map", "has_base": False}, status=404)
        rows, cols = occupancy.shape
        return web.json_response(
            {
                "has_base": True,
                "resolution": occupancy.resolution,
                "origin": list(occupancy.origin),
                "cells": [cols, rows],
                "image": "/api/map.png",
                "locations": [{"name": p.name, "x": p.x, "y": p.y} for p in occupancy.poses],
            }
        )

    async def machine(self) -> MachineSpec:
        """The state machine of the recorded configuration (404 if the recording holds none)."""
        await self._view()
        assert self.recording is not None
        text = self.recording.config_text
        if not text:
            raise web.HTTPNotFound(text="this recording holds no configuration, so no state machine")
        from cyborg.app.config import parse_config

        source = f"{self.recording.path.name}:{self.recording.metadata.get('config')}"
        try:
            return parse_config(text, source=source).machine
        except CyborgError as exc:
            raise web.HTTPNotFound(text=f"the recorded configuration cannot be read here: {exc}") from None

    async def get_machine(self, request: web.Request) -> web.Response:
        """The recorded state machine, as the live API's ``/api/machine`` gives it."""
        machine = await self.machine()
        states = [
            {"name": st.name, "parent": st.parent, "leaf": st.is_leaf, "transitions": dict(st.transitions)}
            for st in machine.states.values()
        ]
        return web.json_response({"initial": machine.initial, "states": states})

    async def _draw(self) -> tuple[bytes, dict[str, Any]]:
        if self._drawing is None:
            machine = await self.machine()

            def work() -> tuple[bytes, dict[str, Any]]:
                from cyborg.drawing.layout import draw, lay_out, run_graphviz

                def run(args: list[str], data: bytes, left: float | None) -> bytes:
                    return run_graphviz(args, data, left, memory=GRAPH_MEMORY)

                layout = lay_out(machine, run, timeout=GRAPH_TIMEOUT)
                return draw(layout, "svg", run, GRAPH_TIMEOUT), {"edges": layout.edges}

            self._drawing = asyncio.ensure_future(asyncio.get_running_loop().run_in_executor(None, work))
        try:
            return await asyncio.shield(self._drawing)
        except CyborgError as exc:
            raise web.HTTPNotFound(text=f"the state machine cannot be drawn here: {exc}") from None

    async def get_graph(self, request: web.Request) -> web.Response:
        """The recorded machine drawn as the live dashboard draws it (ids ``state:<leaf>``,
        ``super:<superstate>``; arrows in ``/api/graph.json``)."""
        svg, _ = await self._draw()
        return web.Response(body=svg, content_type="image/svg+xml")

    async def get_graph_arrows(self, request: web.Request) -> web.Response:
        _, arrows = await self._draw()
        return web.json_response({"layout": "graphviz", **arrows})

    async def get_map_image(self, request: web.Request) -> web.Response:
        from cyborg.web.dashboard import map_png

        occupancy = await self.occupancy()
        if occupancy is None:
            raise web.HTTPNotFound(text="this recording holds no map")
        if self._png is None:
            factor = max(1, math.ceil(max(occupancy.shape) / MAP_PIXELS))
            self._png = await asyncio.get_running_loop().run_in_executor(None, map_png, occupancy, factor)
        return web.Response(body=self._png, content_type="image/png")


def serve_replay(api: ReplayAPI, host: str, port: int, announce: Callable[[str], None]) -> None:
    """Serve ``api`` on ``host:port`` (0: any free port) until interrupted; ``announce`` gets the address."""

    async def serve() -> None:
        runner = web.AppRunner(api.app, access_log=None)
        await runner.setup()
        site = web.TCPSite(runner, host, port)
        await site.start()
        server = site._server
        sockets = getattr(server, "sockets", None) or []
        bound = sockets[0].getsockname()[1] if sockets else port
        announce(f"http://{host}:{bound}/")
        try:
            await asyncio.Event().wait()
        finally:
            await runner.cleanup()

    asyncio.run(serve())
