"""The local HTTP API a running robot serves (documented with OpenAPI).

The command tool (`cyborg event`, `cyborg say`, `cyborg emotion ...`,
`cyborg status`) and the dashboard talk to it. It is a node on the robot's
transport: commands become messages on the thesis's topics, and everything the
robot does arrives as records (see :mod:`cyborg.observe.records`), kept in a ring
buffer and streamed over a websocket. Bound to 127.0.0.1 unless told otherwise.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
import subprocess
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from aiohttp import WSCloseCode, WSMsgType, web

from cyborg.controller.machine import MachineSpec
from cyborg.controller.regions import Lanes, Regions
from cyborg.emotion.model import EmotionSettings
from cyborg.errors import CyborgError
from cyborg.limits import MAX_TEXT_LENGTH
from cyborg.observe.records import Record, RecordStream
from cyborg.transport import topics
from cyborg.transport.base import Node
from cyborg.transport.messages import EmotionalFeedback, String
from cyborg.web.access import DEFAULT_PORT as DEFAULT_PORT
from cyborg.web.security import Access, Guard, needs_token, new_token

log = logging.getLogger(__name__)

RECORD_BUFFER = 5000
GRAPH_MAX_STATES = 10_000  # more leaf states are shown as a list (5,000 are laid out in about 2 s)
GRAPH_TIMEOUT = 10.0  # real seconds Graphviz may take to lay out the machine (once per machine)
GRAPH_MEMORY = 2**30  # bytes of address space each Graphviz run may use
# machine hash -> svg, how, arrows: one per process
_DRAWINGS: dict[str, tuple[bytes, str, dict[str, Any]]] = {}


class CommandError(CyborgError, web.HTTPBadRequest):
    """A request the API refuses: answered 400 Bad Request with ``{"error": problem}``."""

    def __init__(self, problem: str) -> None:
        super().__init__(text=json.dumps({"error": problem}), content_type="application/json")


ROUTES = [
    ("GET", "/api/status", "get_status"),
    ("POST", "/api/event", "post_event"),
    ("POST", "/api/say", "post_say"),
    ("POST", "/api/emotion/set", "post_emotion_set"),
    ("POST", "/api/emotion/values", "post_emotion_values"),
    ("POST", "/api/emotion/switch", "post_emotion_switch"),
    ("GET", "/api/records", "get_records"),
    ("GET", "/api/openapi.json", "get_openapi"),
    ("GET", "/api/ws", "websocket"),
    ("GET", "/api/machine", "get_machine"),
    ("GET", "/api/graph.svg", "get_graph"),
    ("GET", "/api/graph.json", "get_graph_arrows"),
    ("GET", "/api/emotions", "get_emotions"),
]
"""The API's routes: method, path and the :class:`RobotAPI` method that answers (the dashboard adds its own)."""


class RobotAPI:
    """HTTP + websocket front of one robot."""

    def __init__(
        self,
        node: Node,
        *,
        machine: MachineSpec | None = None,
        extra_status: Callable[[], dict[str, Any]] | None = None,
        settle: Callable[[], None] | None = None,
        emotions: dict[str, tuple[float, float, float]] | None = None,
        emotion_aliases: dict[str, str] | None = None,
        access: Access | None = None,
    ) -> None:
        self.node = node
        self.machine = machine
        self.emotions = emotions or {}
        self.emotion_aliases = emotion_aliases or {}
        self._emotion_settings = (
            EmotionSettings.model_validate({"prototypes": self.emotions, "aliases": self.emotion_aliases})
            if self.emotions
            else None
        )  # to refuse a name the emotion system does not know, as it would only log a warning
        self._graph: asyncio.Future[tuple[bytes, str, dict[str, Any]]] | None = None  # shared by all requests
        self._dots: list[subprocess.Popen[bytes]] = []  # Graphviz laying the machine out now
        self.guard = Guard(access or Access())
        self.extra_status = extra_status
        self.settle = settle
        """Waits (off the loop) until what the robot saves is written, so a command's answer can
        say whether its change was saved (the in-process robot's store writes on its own thread)."""
        self.records: deque[Record] = deque(maxlen=RECORD_BUFFER)
        self._events_of: dict[str, tuple[str, ...]] = {}  # state -> valid events, sorted
        parallel = machine is not None and any(state.parallel for state in machine.states.values())
        self._lanes = Lanes(Regions(machine)) if machine is not None and parallel else None  # region -> state
        self.sequence = 0
        self.status: dict[str, Any] = {
            "state": None,
            "previous_state": None,
            "event": None,
            "emotion": "neutral",
            "pleasure": 0.0,
            "arousal": 0.0,
            "dominance": 0.0,
        }
        self._sockets: dict[web.WebSocketResponse, asyncio.Queue[str]] = {}
        self.stream = RecordStream(node)
        self.stream.listeners.append(self._on_record)
        self._events = node.publisher(topics.REGISTER_EVENT, String)
        self._heard = node.publisher(topics.TEXT_FROM_SPEECH, String)
        self._set_emotion = node.publisher(topics.SET_EMOTIONAL_STATE, String)
        self._set_values = node.publisher(topics.SET_EMOTIONAL_VALUES, EmotionalFeedback)
        self._switch = node.publisher(topics.EMOTIONAL_CONTROLLER, String)
        self.app = web.Application(
            middlewares=[self.guard.middleware], client_max_size=self.guard.limits.max_body
        )
        self.app.add_routes(
            web.route(method, path, getattr(self, handler)) for method, path, handler in ROUTES
        )
        self._runner: web.AppRunner | None = None
        self._server: asyncio.Server | None = None
        self.port: int | None = None

    # --- records ------------------------------------------------------------------------

    def _on_record(self, record: Record) -> None:
        self.sequence += 1
        record = {"seq": self.sequence, **record}
        self.records.append(record)
        kind = record["type"]
        if kind == "state":
            self.status.update(state=record["to"], previous_state=record["from"], event=record["event"])
            if self._lanes is not None and record["to"] in self._lanes.regions.machine.states:
                self._lanes.on_change(record["to"], 0.0)
        elif kind == "emotion":
            self.status.update(
                emotion=record["emotion"],
                pleasure=record["pleasure"],
                arousal=record["arousal"],
                dominance=record["dominance"],
            )
        if self._sockets:
            text = json.dumps(record)
            for queue in self._sockets.values():
                if queue.full():
                    queue.get_nowait()  # a slow browser loses the oldest records, not the robot's time
                queue.put_nowait(text)

    def _valid_events(self, state: str) -> tuple[str, ...]:
        """The events valid in ``state``, sorted; worked out once per state (the machine stays as built)."""
        events = self._events_of.get(state)
        if events is None:
            assert self.machine is not None
            events = self._events_of[state] = tuple(sorted(self.machine.transitions_of(state)))
        return events

    def current_status(self) -> dict[str, Any]:
        status = dict(self.status)
        state = status.get("state")
        status["valid_events"] = list(self._valid_events(state)) if self.machine and state else []
        if self._lanes is not None and self._lanes.states:  # in a parallel state: any region's
            status["valid_events"] = sorted(
                {e for leaf in self._lanes.states.values() for e in self._valid_events(leaf)}
            )
        status["time"] = self.node.clock.now()
        if self.extra_status is not None:
            status.update(self.extra_status())
        return status

    # --- handlers -------------------------------------------------------------------------

    async def _json(self, request: web.Request) -> dict[str, Any]:
        try:
            body = await request.json()
        except (ValueError, RecursionError):  # also numbers of over 4300 digits and very deep nesting
            raise CommandError('the body is not usable JSON; send e.g. {"name": "music_play"}') from None
        if not isinstance(body, dict):
            raise CommandError("the body must be a JSON object")
        return body

    @staticmethod
    def _text_field(body: dict[str, Any], key: str) -> str:
        value = body.get(key)
        if not isinstance(value, str) or not value.strip():
            raise CommandError(f"{key!r} must be a non-empty string")
        return value.strip()

    async def get_status(self, request: web.Request) -> web.Response:
        return web.json_response(self.current_status())

    async def _unsaved(self) -> dict[str, Any]:
        """What an emotion command's answer adds while the robot cannot save its data (``storage``
        in the status says so): the change is made in memory only. Nothing where that is not known.

        It first lets the loop run once: an emotion system in this process (the embedded transport
        delivers with ``call_soon``) has then applied the command and handed it to its store, whose
        write it then waits for (``settle``)."""
        await asyncio.sleep(0)
        if self.settle is not None:
            await asyncio.get_running_loop().run_in_executor(None, self.settle)
        storage = self.extra_status().get("storage") if self.extra_status is not None else None
        if not isinstance(storage, dict) or storage.get("saved") is not False:
            return {}
        return {
            "saved": False,
            "warning": f"the robot is not saving its data ({storage.get('problem')}; fix: {storage.get('fix')}): "
            "it makes this change in memory only, and saves it once writes work again",
        }

    async def post_event(self, request: web.Request) -> web.Response:
        name = self._text_field(await self._json(request), "name")
        self._events.publish(String(data=name))
        valid = self.current_status()["valid_events"]
        return web.json_response({"sent": name, "is_transition": name in valid if self.machine else None})

    async def post_say(self, request: web.Request) -> web.Response:
        text = self._text_field(await self._json(request), "text")
        if len(text) > MAX_TEXT_LENGTH:
            raise CommandError(
                f"'text' has {len(text)} characters, over the limit of {MAX_TEXT_LENGTH}; send one sentence"
            )
        self._heard.publish(String(data=text))
        return web.json_response({"sent": text})

    async def post_emotion_set(self, request: web.Request) -> web.Response:
        name = self._text_field(await self._json(request), "name")
        emotion = name
        if self._emotion_settings is not None:
            try:
                emotion = self._emotion_settings.resolve(name[:100])  # an alias names its emotion
            except ValueError as exc:
                raise CommandError(str(exc)) from None
        self._set_emotion.publish(String(data=name))
        return web.json_response({"sent": name, "emotion": emotion, **await self._unsaved()})

    async def post_emotion_values(self, request: web.Request) -> web.Response:
        body = await self._json(request)
        values = []
        for key in ("pleasure", "arousal", "dominance"):
            value = body.get(key)
            if (
                not isinstance(value, int | float)
                or isinstance(value, bool)
                or not math.isfinite(value)
                or abs(value) > 1
            ):
                raise CommandError(f"{key!r} must be a number in [-1, 1], got {value!r}")
            values.append(float(value))
        self._set_values.publish(EmotionalFeedback(*values))
        return web.json_response(
            {
                "sent": dict(zip(("pleasure", "arousal", "dominance"), values, strict=True)),
                **await self._unsaved(),
            }
        )

    async def post_emotion_switch(self, request: web.Request) -> web.Response:
        body = await self._json(request)
        on = body.get("on")
        if not isinstance(on, bool):
            raise CommandError("'on' must be true or false")
        self._switch.publish(String(data="on" if on else "off"))
        return web.json_response({"sent": "on" if on else "off", **await self._unsaved()})

    async def get_records(self, request: web.Request) -> web.Response:
        try:
            since = int(request.query.get("since", "0"))
        except ValueError:
            raise CommandError("'since' must be a record sequence number") from None
        kinds = set(filter(None, request.query.get("type", "").split(",")))
        out = [r for r in self.records if r["seq"] > since and (not kinds or r["type"] in kinds)]
        return web.json_response(out)

    async def get_machine(self, request: web.Request) -> web.Response:
        if self.machine is None:
            raise web.HTTPNotFound(text="this robot's state machine is not known here")
        states = [
            {
                "name": st.name,
                "parent": st.parent,
                "action": st.action,
                "leaf": st.is_leaf,
                "transitions": dict(st.transitions),
                "resources": self.machine.resources_of(st.name) if st.is_leaf else dict(st.resources),
            }
            for st in self.machine.states.values()
        ]
        return web.json_response({"initial": self.machine.initial, "states": states})

    async def _drawing(self) -> tuple[bytes, str, dict[str, Any]]:
        if self.machine is None:
            raise web.HTTPNotFound(text="this robot's state machine is not known here")
        if self._graph is None:
            self._graph = asyncio.ensure_future(self._lay_out(self.machine))
        return await asyncio.shield(self._graph)

    async def get_graph(self, request: web.Request) -> web.Response:
        """The machine drawn by Graphviz; ids ``state:<leaf>``, ``super:<superstate>`` and
        ``edge:<state>:<event>`` for live highlighting (see /api/graph.json for what each arrow shows).

        Laid out once per machine (every request waits for the same layout), each Graphviz run
        within a time and memory cap; a machine too big for that is shown as a list (header
        ``X-Graph-Layout: list``).
        """
        svg, layout, _ = await self._drawing()
        return web.Response(body=svg, content_type="image/svg+xml", headers={"X-Graph-Layout": layout})

    async def get_graph_arrows(self, request: web.Request) -> web.Response:
        """How the drawing was made and, per arrow id, the [state, event] transitions it shows."""
        _, layout, info = await self._drawing()
        return web.json_response({"layout": layout, **info})

    async def _lay_out(self, machine: MachineSpec) -> tuple[bytes, str, dict[str, Any]]:
        from cyborg.drawing.graph import list_svg
        from cyborg.drawing.layout import draw, lay_out, machine_key, run_graphviz

        key = machine_key(machine)
        if key in _DRAWINGS:
            return _DRAWINGS[key]
        leaves = len(machine.leaves())
        if leaves > GRAPH_MAX_STATES:
            note = (
                f"{leaves} states: more than the {GRAPH_MAX_STATES} laid out as a graph here, so a list. "
                "Fix: draw it offline with `cyborg graph FILE -o machine.svg`"
            )
            return list_svg(machine, note), "list", {"edges": {}}

        def started(process: subprocess.Popen[bytes]) -> None:
            self._dots.append(process)

        def run(args: list[str], data: bytes, left: float | None) -> bytes:
            return run_graphviz(args, data, left, memory=GRAPH_MEMORY, started=started)

        def work() -> tuple[bytes, dict[str, Any]]:
            began = time.perf_counter()
            layout = lay_out(machine, run, timeout=GRAPH_TIMEOUT)
            svg = draw(layout, "svg", run, GRAPH_TIMEOUT)
            return svg, {"edges": layout.edges, "seconds": round(time.perf_counter() - began, 3)}

        try:
            svg, info = await asyncio.get_running_loop().run_in_executor(None, work)
        except (CyborgError, OSError) as exc:
            log.warning("the dashboard shows the state machine as a list: %s", exc)
            return list_svg(machine, f"Shown as a list: {exc}"), "list", {"edges": {}}
        finally:
            self._dots.clear()
        if len(_DRAWINGS) >= 4:
            _DRAWINGS.clear()
        _DRAWINGS[key] = (svg, "graphviz", info)
        return _DRAWINGS[key]

    async def get_emotions(self, request: web.Request) -> web.Response:
        return web.json_response(
            {"prototypes": {k: list(v) for k, v in self.emotions.items()}, "aliases": self.emotion_aliases}
        )

    async def get_openapi(self, request: web.Request) -> web.Response:
        from cyborg.web.openapi import OPENAPI

        return web.json_response(OPENAPI)

    async def websocket(self, request: web.Request) -> web.WebSocketResponse:
        self.guard.websocket_allowed(len(self._sockets))
        socket = web.WebSocketResponse(heartbeat=20, max_msg_size=self.guard.limits.max_ws_message)
        await socket.prepare(request)
        queue: asyncio.Queue[str] = asyncio.Queue(maxsize=1000)
        self._sockets[socket] = queue
        await socket.send_str(json.dumps({"type": "hello", "status": self.current_status()}))

        async def pump() -> None:
            while not socket.closed:
                await socket.send_str(await queue.get())

        sender = asyncio.ensure_future(pump())
        try:
            async for message in socket:
                if message.type is WSMsgType.ERROR:
                    break
        finally:
            sender.cancel()
            self._sockets.pop(socket, None)
        return socket

    # --- serving --------------------------------------------------------------------------

    @property
    def token(self) -> str | None:
        """The bearer token every /api/ request needs, if any (see :mod:`cyborg.web.security`)."""
        return self.guard.access.token

    async def start(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT) -> str:
        """Serve on ``host``:``port``; returns the address of the page. Beyond loopback a token is
        required: without one given, one is made here (read it from :attr:`token`)."""
        if self.guard.access.token is None and needs_token(host):
            self.guard.access.token = new_token()
        clock = self.node.clock
        speed = getattr(clock, "speed", 1.0) if clock.is_virtual else 1.0
        # The loop's timers run on the robot's clock: scale the real-time limit; none at --speed max.
        timeout = self.guard.limits.header_timeout * speed if speed else 0.0
        self._runner = web.AppRunner(self.app, access_log=None, keepalive_timeout=timeout)
        await self._runner.setup()
        assert self._runner.server is not None
        accept = self.guard.protocol_factory(self._runner.server, speed or 0.0)
        self._server = await asyncio.get_running_loop().create_server(
            accept, host or None, port, reuse_address=True, backlog=128
        )
        sockets = self._server.sockets
        self.port = sockets[0].getsockname()[1] if sockets else port
        self.guard.bind(host, self.port)
        return self.guard.public_url

    async def stop(self) -> None:
        for dot in list(self._dots):
            if dot.poll() is None:
                dot.kill()  # a layout still running is of no use once the robot stops
        for socket in list(self._sockets):
            await socket.close(code=WSCloseCode.GOING_AWAY, message=b"the robot stopped")
        if self._server is not None:
            self._server.close()
        if self._runner is not None:
            await self._runner.cleanup()
            self._runner = None
        if self._server is not None:
            await self._server.wait_closed()
            self._server = None
