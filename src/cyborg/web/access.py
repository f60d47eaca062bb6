"""Who may use the robot's HTTP API, as the command line and its clients see it: the access
policy (token, allowed origins, limits), the client's headers and what a server announces.

Kept apart from :mod:`cyborg.web.security` (the server's checks, on aiohttp) so that the
command line and the command tool import neither aiohttp nor yarl: ``cyborg --help`` and
``cyborg say`` stay quick.
"""

from __future__ import annotations

import ipaddress
import secrets
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from cyborg.errors import InvalidValueError

if TYPE_CHECKING:
    from yarl import URL

DEFAULT_PORT = 8642  # of the API and dashboard
TOKEN_ENV = "CYBORG_TOKEN"
LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})
WILDCARDS = frozenset({"", "0.0.0.0", "::"})


@dataclass(frozen=True)
class Limits:
    """How much the API takes from one client, and from all of them together."""

    max_body: int = 64 * 1024  # bytes of a command's body
    header_timeout: float = 10.0  # real seconds to send a request, or the next one on a kept-alive connection
    body_timeout: float = 10.0  # real seconds to send a command's body once its headers are in
    max_connections: int = 512
    grace: float = 1.0  # real seconds a new connection has to start its request before it may make room
    max_websockets: int = 64
    max_ws_message: int = 4096  # bytes a client may send on the websocket (it is read and ignored)


@dataclass
class Access:
    """The API's access policy: an optional bearer token and extra origins allowed in."""

    token: str | None = None
    allowed_origins: tuple[str, ...] = ()
    limits: Limits = field(default_factory=Limits)


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def needs_token(host: str) -> bool:
    """Binding to anything but a loopback address serves other machines: a token is required."""
    return not is_loopback(host)


def new_token() -> str:
    return secrets.token_urlsafe(24)


def parse_origin(value: str) -> str:
    """``--allow-origin``: ``http(s)://name[:port]``, normalised; raises InvalidValueError (a ValueError) naming the fix."""
    from yarl import URL

    url = URL(value.strip())
    if url.scheme not in ("http", "https") or not url.host or url.path not in ("", "/") or url.query_string:
        raise InvalidValueError(
            f"{value!r} is not an origin; fix: give scheme, name and port only, e.g. http://cyborg.local:8642"
        )
    return _origin_of(url)


def _origin_of(url: URL) -> str:
    default = 443 if url.scheme == "https" else 80
    port = "" if url.port in (None, default) else f":{url.port}"
    host = f"[{url.host}]" if url.host and ":" in url.host else url.host
    return f"{url.scheme}://{host}{port}"


def allowed_origins(values: Iterable[str]) -> tuple[str, ...]:
    """Parse ``--allow-origin`` values; raises ValueError naming the bad one and the fix."""
    return tuple(parse_origin(v) for v in values)


def client_headers(token: str | None) -> dict[str, Any]:
    """Headers a client of the API sends: the bearer token when there is one."""
    return {"Authorization": f"Bearer {token}"} if token else {}


def announcement(url: str, host: str, port: int, token: str | None, generated: bool) -> list[tuple[str, str]]:
    """What a server prints at start, as (text, colour): the page's address (with the token for
    the page to keep), how the command tool gets in, and a warning when serving beyond loopback."""
    base = url.rstrip("/")
    lines: list[tuple[str, str]] = []
    if needs_token(host):
        lines.append(
            (
                f"warning: serving on {host}:{port}, beyond this machine: whoever reaches that address "
                "and holds the token below can command the robot and hear everything it hears and says; "
                "the token travels unencrypted over HTTP. Use a trusted network, or keep --host 127.0.0.1 "
                f"and tunnel (ssh -L {port}:127.0.0.1:{port} ROBOT). See docs/security.md",
                "yellow",
            )
        )
    page = f"{url}#token={token}" if token else url
    tool = f"{TOKEN_ENV}={token} cyborg status --url {base}" if token else f"cyborg status --url {base}"
    lines.append((f"dashboard and API: {page}  (command tool: {tool})", "green"))
    if host in WILDCARDS:
        lines.append(
            (
                f"from other machines: http://THIS-MACHINE'S-ADDRESS:{port}/"
                + (f"#token={token}" if token else ""),
                "green",
            )
        )
    if token and generated:
        lines.append((f"token generated for this run; give your own with --token or ${TOKEN_ENV}", "green"))
    return lines
