"""The live dashboard's look back and mark: the last minutes of the running robot, from its recording.

An extension of the robot's API (an entry of :data:`cyborg.web.build.EXTENSIONS`). It follows the
flight recorder's status topic (the recorder runs in this process with ``cyborg sim``, or as the
``cyborg_recorder`` node of a launch), and adds:

- ``GET /api/recorder``: whether the robot is recording, to which file, or why it stopped;
- ``POST /api/mark`` ``{"note": "..."}``: a note put into the recording at this moment;
- ``GET /lookback``: the replay page (:file:`static/replay.html`) on the last minutes, whose API is
  ``GET /api/lookback/replay?minutes=N`` (asks the recorder to write out what it holds back, then
  reads the current segment and the one before), ``/api/lookback/status?at=`` and
  ``/api/lookback/records?at=``, as ``cyborg replay`` answers them.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import logging
import math
from pathlib import Path
from typing import Any

from aiohttp import web

from cyborg.app.view import RobotView
from cyborg.observe import channels as ch
from cyborg.observe.recording import Recording, RecordingError, open_recording
from cyborg.observe.records import NS_PER_S
from cyborg.transport.base import MessageInfo
from cyborg.transport.messages import String
from cyborg.web.api import CommandError, RobotAPI
from cyborg.web.dashboard import STATIC_DIR
from cyborg.web.replay import ReplayView

__all__ = ["DEFAULT_MINUTES", "Lookback", "register"]

log = logging.getLogger(__name__)

DEFAULT_MINUTES = 10.0
"""How far the look back reaches unless asked otherwise."""
MAX_NOTE = 500
FLUSH_WAIT = 2.0
"""Seconds of the robot's clock to wait for the recorder to write out what it holds back."""


class Lookback:
    """The look back and mark endpoints of one robot's API (see the module docstring)."""

    def __init__(self, api: RobotAPI) -> None:
        self.api = api
        node = api.node
        self.recorder: dict[str, Any] | None = None
        """The recorder's last status (None: no recorder has spoken)."""
        self.view: ReplayView | None = None
        self._marks = node.publisher(ch.MARK_TOPIC, String)
        self._flush = node.publisher(ch.FLUSH_TOPIC, String)
        self._flushed: dict[str, asyncio.Future[None]] = {}
        self._ids = itertools.count(1)
        node.subscribe(ch.RECORDER_STATUS_TOPIC, String, self._on_status, queue_size=10)

    def routes(self) -> list[web.RouteDef]:
        return [
            web.get("/api/recorder", self.get_recorder),
            web.post("/api/mark", self.post_mark),
            web.get("/lookback", self.page),
            web.get("/api/lookback/replay", self.get_replay),
            web.get("/api/lookback/status", self.get_status),
            web.get("/api/lookback/records", self.get_records),
        ]

    def _on_status(self, message: String, info: MessageInfo) -> None:
        try:
            status = json.loads(message.data)
        except ValueError:
            return
        if not isinstance(status, dict):
            return
        self.recorder = status
        waiter = self._flushed.pop(str(status.get("flushed")), None)
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    def _recording(self) -> dict[str, Any]:
        """The recorder's status, or a CommandError saying why there is nothing to look at."""
        status = self.recorder
        if status is None:
            raise CommandError(
                "this robot is not recording (no flight recorder has spoken); fix: start it without "
                "--no-record, with the configuration's recording: enabled: true"
            )
        if not status.get("recording"):
            raise CommandError(
                str(
                    status.get("problem")
                    or f"the recorder is {status.get('state')}; fix: start the robot again"
                )
            )
        return status

    async def get_recorder(self, request: web.Request) -> web.Response:
        status = self.recorder or {"recording": False, "state": "none", "file": None, "problem": None}
        return web.json_response({k: v for k, v in status.items() if k != "flushed"})

    async def post_mark(self, request: web.Request) -> web.Response:
        self._recording()
        body = await self.api._json(request)
        note = body.get("note", "mark")
        if not isinstance(note, str):
            raise CommandError("'note' must be a string (what to remember about this moment)")
        note = note.strip()[:MAX_NOTE] or "mark"
        self._marks.publish(String(data=note))
        return web.json_response({"marked": note, "time": self.api.node.clock.now()})

    async def page(self, request: web.Request) -> web.FileResponse:
        return web.FileResponse(STATIC_DIR / "replay.html")

    async def _write_out(self) -> None:
        """Ask the recorder to write out its held-back chunk; wait a little for it to say so."""
        request = str(next(self._ids))
        waiter: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._flushed[request] = waiter
        self._flush.publish(String(data=request))
        try:
            await asyncio.wait_for(waiter, FLUSH_WAIT)
        except TimeoutError:
            log.info("the recorder did not answer the look back's flush; reading what is written")
        finally:
            self._flushed.pop(request, None)

    async def get_replay(self, request: web.Request) -> web.Response:
        status = self._recording()
        raw = request.query.get("minutes", str(DEFAULT_MINUTES))
        try:
            minutes = float(raw)
        except ValueError:
            minutes = math.nan
        if not math.isfinite(minutes) or minutes <= 0:
            raise CommandError(
                f"'minutes' must be a positive number of minutes to look back, got {raw[:40]!r}"
            )
        await self._write_out()
        status = self.recorder or status
        files = [Path(f) for f in status.get("files") or [status["file"]] if f]
        recording = await asyncio.get_running_loop().run_in_executor(None, read_segments, files)
        self.view = ReplayView(recording, live=True)
        self.view.begin_ns = max(0, self.view.end_ns - round(minutes * 60 * NS_PER_S))
        return web.json_response(self.view.info())

    def _view(self) -> ReplayView:
        if self.view is None:
            raise CommandError("nothing looked back at yet; fix: GET /api/lookback/replay first")
        return self.view

    async def get_status(self, request: web.Request) -> web.Response:
        view = self._view()
        return web.json_response(view.status_at(view.at(request.query.get("at"))))

    async def get_records(self, request: web.Request) -> web.Response:
        view = self._view()
        return web.json_response(view.records_at(view.at(request.query.get("at"))))


def read_segments(files: list[Path]) -> Recording:
    """The recording in ``files`` (one run's segments, oldest first) read as one, up to what is
    written (the newest is still being written); a segment gone (the budget) is left out."""
    parts: list[Recording] = []
    for path in files:
        try:
            parts.append(open_recording(path))
        except RecordingError as exc:
            if path.exists() or path == files[-1]:
                raise CommandError(f"cannot look back: {exc}") from None
    whole = parts[-1]
    for older in reversed(parts[:-1]):
        whole = Recording(
            whole.path,
            whole.metadata,
            {**older.attachments, **whole.attachments},
            older.records + whole.records,
            older.inputs + whole.inputs,
            older.events + whole.events,
            older.marks + whole.marks,
            older.logs + whole.logs,
        )
    return whole


def register(api: RobotAPI, robot: RobotView) -> None:
    """Add the look back and mark to ``api`` (an entry of :data:`cyborg.web.build.EXTENSIONS`)."""
    api.app.add_routes(Lookback(api).routes())
