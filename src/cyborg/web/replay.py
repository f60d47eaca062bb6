"""``cyborg replay``: the dashboard on a recording, at any moment of it.

Serves :file:`static/replay.html` (a time slider, play/pause and speed; at the slider's moment the
active state and last transition, the emotion and its plot, the robot's track on the map and the
log up to then) and a read-only API that answers as the robot's would have at that moment:
``GET /api/status?at=SECONDS`` (seconds since the recording started), ``GET /api/records?at=``
and ``GET /api/replay`` (what the recording is: its span, metadata and marks). The recording is
read once; a moment is then a binary search per record type.
"""

from __future__ import annotations

import asyncio
import bisect
import math
from collections.abc import Callable, Sequence
from typing import Any

from aiohttp import web

from cyborg.observe.recording import Recording
from cyborg.observe.records import NS_PER_S, Record
from cyborg.web.dashboard import STATIC_DIR

__all__ = ["ReplayAPI", "serve_replay"]

RECORDS_SHOWN = 200
"""The log's records up to a moment that ``/api/records`` gives (the latest)."""
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


class ReplayAPI:
    """The read-only API of one recording (see the module docstring)."""

    def __init__(self, recording: Recording) -> None:
        self.recording = recording
        by_type: dict[str, list[Record]] = {}
        for record in recording.records:
            by_type.setdefault(str(record["type"]), []).append(record)
        self.timelines = {kind: _Timeline(records) for kind, records in by_type.items()}
        self.all = _Timeline(recording.records)
        self.app = web.Application()
        self.app.add_routes(
            [
                web.get("/", self.index),
                web.get("/api/replay", self.get_replay),
                web.get("/api/status", self.get_status),
                web.get("/api/records", self.get_records),
                web.static("/static", STATIC_DIR),
            ]
        )

    def _at(self, request: web.Request) -> int:
        raw = request.query.get("at")
        if raw is None:
            return self.recording.end_ns
        try:
            seconds = float(raw)
        except ValueError:
            seconds = math.nan
        if not math.isfinite(seconds) or seconds < 0:
            raise web.HTTPBadRequest(
                text=f"'at' must be seconds since the recording started (0 to "
                f"{self.recording.end_ns / NS_PER_S:g}), got {raw[:40]!r}"
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

    async def index(self, request: web.Request) -> web.FileResponse:
        return web.FileResponse(STATIC_DIR / "replay.html")

    async def get_replay(self, request: web.Request) -> web.Response:
        recording = self.recording
        poses = self.timelines.get("pose")
        every = max(1, len(poses.records) // TRACK_POINTS) if poses else 1
        track = [[r["t"], r["x"], r["y"]] for r in poses.records[::every]] if poses else []
        emotions = self.timelines.get("emotion")
        plot = (
            [[r["t"], r["pleasure"], r["arousal"], r["dominance"]] for r in emotions.records]
            if emotions
            else []
        )
        return web.json_response(
            {
                "file": recording.path.name,
                "duration": recording.end_ns / NS_PER_S,
                "records": len(recording.records),
                "metadata": recording.metadata,
                "marks": [{"t": m["t_ns"] / NS_PER_S, "note": m.get("note")} for m in recording.marks],
                "problem": recording.problem,
                "track": track,
                "emotions": plot,
            }
        )

    async def get_status(self, request: web.Request) -> web.Response:
        return web.json_response(self.status_at(self._at(request)))

    async def get_records(self, request: web.Request) -> web.Response:
        t_ns = self._at(request)
        index = bisect.bisect_right(self.all.times, t_ns)
        return web.json_response(self.all.records[max(0, index - RECORDS_SHOWN) : index])


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
