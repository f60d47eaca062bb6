"""Who may use the robot's HTTP API, and how much of it (docs/security.md explains the choices).

* ``Host`` must name this robot: the address it was started on (a loopback name when that is
  loopback; any IP literal or the machine's own name when it binds every address), or one
  added with ``--allow-origin``. A DNS-rebinding page arrives with its own name and is refused.
* ``Origin``, when a browser sends one (every POST and every websocket), must be the robot's
  own page or an added origin: a page of another site or port can neither command the robot
  nor read its websocket.
* Commands (POST) take only ``Content-Type: application/json``: no HTML form and no
  ``text/plain`` "simple request" is read as JSON.
* With a token (required when binding beyond loopback) every ``/api/`` request carries
  ``Authorization: Bearer TOKEN`` (the websocket, which browsers cannot give headers, may
  carry ``?token=TOKEN`` instead). The page and its static files stay public.
* Limits: a request body of at most ``max_body`` bytes, a connection must send its request
  (and an idle keep-alive connection its next one) within ``header_timeout`` seconds, at most
  ``max_connections`` connections (the oldest idle one makes room for a new one) and
  ``max_websockets`` live streams. Every refusal names the limit and the fix.
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import json
import resource
import secrets
import socket
from collections.abc import Awaitable, Callable
from typing import NoReturn

from aiohttp import hdrs, web
from aiohttp.web_protocol import RequestHandler
from yarl import URL

from cyborg.web.access import LOOPBACK_NAMES as LOOPBACK_NAMES
from cyborg.web.access import TOKEN_ENV as TOKEN_ENV
from cyborg.web.access import WILDCARDS as WILDCARDS
from cyborg.web.access import Access as Access
from cyborg.web.access import Limits as Limits
from cyborg.web.access import allowed_origins as allowed_origins
from cyborg.web.access import announcement as announcement
from cyborg.web.access import client_headers as client_headers
from cyborg.web.access import is_loopback as is_loopback
from cyborg.web.access import needs_token as needs_token
from cyborg.web.access import new_token as new_token
from cyborg.web.access import parse_origin as parse_origin

FD_RESERVE = 128  # files kept free for the robot itself (databases, Graphviz, logs)
WANTED_FILES = 65536  # the open-file limit we raise to, if the hard limit allows


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


def _problem(response: type[web.HTTPException], problem: str, **headers: str) -> web.HTTPException:
    return response(text=json.dumps({"error": problem}), content_type="application/json", headers=headers)


def raise_file_limit() -> int:
    """Raise this process's soft limit of open files towards the hard one; returns the soft limit.

    The usual soft limit of 1,024 is reached by a thousand idle connections; the hard limit
    (often 524,288) is the administrator's, and we stay under it.
    """
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    wanted = WANTED_FILES if hard == resource.RLIM_INFINITY else min(hard, WANTED_FILES)
    if soft != resource.RLIM_INFINITY and soft < wanted:
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(resource.RLIMIT_NOFILE, (wanted, hard))
            soft = wanted
    return int(soft) if soft != resource.RLIM_INFINITY else WANTED_FILES


class Guard:
    """The checks above for one server: its middleware and its connection limit."""

    def __init__(self, access: Access) -> None:
        self.access = access
        self.limits = access.limits
        self.host = "127.0.0.1"
        self.port = 0
        self.public_url = ""
        self._names: set[str] = set()
        self._any_ip = False
        self._origins: set[str] = set()
        self._authorities: set[str] = set()
        self._busy: dict[RequestHandler, int] = {}
        self._evicted: set[RequestHandler] = set()  # closed to make room, not yet gone
        self._opened: dict[RequestHandler, float] = {}  # open connection -> when (loop time)
        self._reading: dict[RequestHandler, float] = {}  # connection reading a body -> since (loop time)
        self._speed = 1.0
        self.max_connections = self.limits.max_connections
        self.refused: dict[str, int] = {}  # why -> how many requests were refused (docs, tests)

    def bind(self, host: str, port: int) -> None:
        """Learn the address the server was started on (port: the one actually bound)."""
        self.host, self.port = host, port
        names = {host.strip("[]").lower()}
        if is_loopback(host) or host in WILDCARDS:
            names |= LOOPBACK_NAMES
        if host in WILDCARDS:
            self._any_ip = True  # an IP literal cannot be rebound; a name could be the attacker's
            names |= {socket.gethostname().lower(), socket.getfqdn().lower()}
        self._names = names - WILDCARDS
        for origin in self.access.allowed_origins:
            url = URL(origin)
            self._origins.add(origin)
            self._authorities.add(origin.split("://", 1)[1])
            if url.port == port and url.host:
                self._names.add(url.host.lower())
        shown = "127.0.0.1" if host in WILDCARDS else host
        shown = f"[{shown}]" if ":" in shown else shown
        self.public_url = f"http://{shown}:{port}/"
        files = raise_file_limit()
        self.max_connections = max(1, min(self.limits.max_connections, files - FD_RESERVE))

    # --- the middleware ---------------------------------------------------------------------

    def _host_allowed(self, value: str) -> bool:
        if value in self._authorities:
            return True
        try:
            url = URL(f"http://{value}")
        except ValueError:
            return False
        name = (url.host or "").lower()
        if url.port != self.port or not name:
            return False
        return name in self._names or (self._any_ip and _is_ip(name))

    def _refuse(self, why: str, response: type[web.HTTPException], problem: str, **headers: str) -> NoReturn:
        self.refused[why] = self.refused.get(why, 0) + 1
        raise _problem(response, problem, **headers)

    def _check(self, request: web.Request) -> None:
        host = request.headers.get(hdrs.HOST)
        if host is not None and not self._host_allowed(host):
            self._refuse(
                "host",
                web.HTTPForbidden,
                f"Host {host!r} is not this robot's address ({self.host}:{self.port}); fix: open "
                f"{self.public_url}, or start the robot with --allow-origin http://{host} if that name "
                "really is this robot (e.g. behind a proxy)",
            )
        origin = request.headers.get(hdrs.ORIGIN)
        if origin is not None:
            own = f"{request.scheme}://{host}" if host is not None else None
            if origin != own and origin not in self._origins:
                self._refuse(
                    "origin",
                    web.HTTPForbidden,
                    f"a page from {origin} may not use this robot's API (only its own page, "
                    f"{self.public_url}, may); fix: open the dashboard at {self.public_url}, or start "
                    f"the robot with --allow-origin {origin} to trust that site",
                )
        token = self.access.token
        if token is not None and request.path.startswith("/api/"):
            given = ""
            scheme, _, credentials = request.headers.get(hdrs.AUTHORIZATION, "").partition(" ")
            if scheme.lower() == "bearer":
                given = credentials.strip()
            elif request.path == "/api/ws":
                given = request.query.get("token", "")
            # aiohttp keeps bytes that are not UTF-8 as surrogates: compare the bytes the client sent.
            if not secrets.compare_digest(given.encode("utf-8", "surrogateescape"), token.encode()):
                self._refuse(
                    "token",
                    web.HTTPUnauthorized,
                    "this robot's API needs its token"
                    + (" (the one given was wrong)" if given else "")
                    + f"; fix: the command tool: --token TOKEN or ${TOKEN_ENV}; the dashboard: open the "
                    "address the robot printed at start (it ends in #token=...); HTTP: send "
                    "'Authorization: Bearer TOKEN'",
                    **{hdrs.WWW_AUTHENTICATE: 'Bearer realm="cyborg"'},
                )
        if request.method not in ("GET", "HEAD", "OPTIONS") and request.content_type != "application/json":
            self._refuse(
                "content-type",
                web.HTTPUnsupportedMediaType,
                f"commands take only Content-Type: application/json, not {request.content_type!r}; "
                "fix: send the JSON body with that header, e.g. "
                "curl -H 'Content-Type: application/json' -d '{\"name\": \"music_play\"}' URL",
            )

    @web.middleware
    async def middleware(
        self, request: web.Request, handler: Callable[[web.Request], Awaitable[web.StreamResponse]]
    ) -> web.StreamResponse:
        self._check(request)
        protocol = request.protocol
        self._busy[protocol] = self._busy.get(protocol, 0) + 1
        try:
            return await handler(request)
        except web.HTTPRequestEntityTooLarge:
            self.refused["body"] = self.refused.get("body", 0) + 1
            problem = (
                f"the body is larger than {self.limits.max_body} bytes, this API's limit; fix: commands "
                'are small JSON objects such as {"text": "hello"}: send less'
            )
            raise web.HTTPRequestEntityTooLarge(
                max_size=self.limits.max_body,
                text=json.dumps({"error": problem}),
                content_type="application/json",
            ) from None
        finally:
            left = self._busy.pop(protocol, 1) - 1
            if left > 0:
                self._busy[protocol] = left

    # --- connections ------------------------------------------------------------------------

    def protocol_factory(self, server: web.Server, speed: float) -> Callable[[], asyncio.Protocol]:
        """Wraps aiohttp's protocol factory. At ``max_connections`` open connections the oldest idle
        one (no request in progress: it never sent one, or is kept alive after one) is closed to
        make room, unless it is younger than ``grace`` (it may be about to send its request); if
        none can go, the new connection gets a 503 naming the limit. ``speed``: loop seconds per
        real second (the robot's clock; 0 at --speed max)."""
        loop = asyncio.get_running_loop()
        grace = self.limits.grace * speed
        self._speed = speed

        def accept() -> asyncio.Protocol:
            now = loop.time()
            live = server.connections
            self._opened = {c: self._opened.get(c, now) for c in live}  # forget the closed ones
            self._evicted.intersection_update(live)
            connections = [c for c in live if c not in self._evicted]
            if len(connections) >= self.max_connections:
                idle = next(
                    (c for c in connections if c not in self._busy and now - self._opened[c] >= grace),
                    None,
                )
                if idle is None:  # then the one that has been sending its body the longest
                    slow = sorted((since, id(c), c) for c, since in self._reading.items() if c in live)
                    if slow and now - slow[0][0] >= grace:
                        idle = slow[0][2]
                        self.refused["slow-body-closed"] = self.refused.get("slow-body-closed", 0) + 1
                if idle is None:
                    self.refused["connections"] = self.refused.get("connections", 0) + 1
                    return _Refused(self._too_many(), grace)
                self._evicted.add(idle)
                self.refused["idle-closed"] = self.refused.get("idle-closed", 0) + 1
                idle.force_close()
            handler = server()
            self._opened[handler] = now
            return handler

        return accept

    async def read_body(self, request: web.Request) -> bytes:
        """The request's body, within ``body_timeout`` real seconds of its headers (408 if not).

        While it arrives the connection may be closed to make room for a new one (at the
        connection limit, after the idle ones): a client that sends a byte a second must not
        lock the dashboard and the command tool out. 400 if the client leaves halfway.
        """
        protocol = request.protocol
        self._reading[protocol] = asyncio.get_running_loop().time()
        limit = self.limits.body_timeout * self._speed
        try:
            async with asyncio.timeout(limit if limit > 0 else None):
                return await request.read()
        except TimeoutError:
            self.refused["slow-body"] = self.refused.get("slow-body", 0) + 1
            problem = (
                f"the body did not arrive within {self.limits.body_timeout:g} s of the headers, this API's "
                "limit; fix: send the whole (small) body at once"
            )
            raise web.HTTPRequestTimeout(
                text=json.dumps({"error": problem}),
                content_type="application/json",
                headers={"Connection": "close"},
            ) from None
        except ConnectionError:
            self.refused["body-abandoned"] = self.refused.get("body-abandoned", 0) + 1
            raise web.HTTPBadRequest(
                text=json.dumps({"error": "the client left before its body arrived"}),
                content_type="application/json",
            ) from None
        finally:
            self._reading.pop(protocol, None)

    def _too_many(self) -> bytes:
        problem = (
            f"the robot's API has {self.max_connections} connections in use, its limit; fix: close "
            "other dashboards, websocket clients or scripts, then retry"
        )
        body = json.dumps({"error": problem}).encode()
        head = (
            "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\n"
            f"Content-Length: {len(body)}\r\nConnection: close\r\nRetry-After: 5\r\n\r\n"
        )
        return head.encode() + body

    def websocket_allowed(self, open_sockets: int) -> None:
        if open_sockets >= self.limits.max_websockets:
            self._refuse(
                "websockets",
                web.HTTPServiceUnavailable,
                f"{open_sockets} live streams are open, this API's limit of {self.limits.max_websockets}; "
                "fix: close other dashboard tabs or `cyborg status --follow` clients",
            )


class _Refused(asyncio.Protocol):
    """A connection over the limit: answers its request with a 503 and closes (or after the timeout)."""

    def __init__(self, answer: bytes, timeout: float) -> None:
        self.answer = answer
        self.timeout = timeout
        self.transport: asyncio.Transport | None = None
        self._timer: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        if self.timeout > 0:  # wait for the request, so the answer is read rather than reset
            self._timer = asyncio.get_running_loop().call_later(self.timeout, transport.close)
        else:
            self.data_received(b"")

    def data_received(self, data: bytes) -> None:
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(self.answer)  # the request has been read: the answer is not reset
            self.transport.close()

    def connection_lost(self, exc: BaseException | None) -> None:
        if self._timer is not None:
            self._timer.cancel()
