"""A client of a running robot's HTTP API (``cyborg sim``, or the ``cyborg_api`` ROS node).

:class:`HttpLink` is what the command tool uses by default (urllib only, so ``cyborg say`` stays
quick); :class:`RobotLink` is what every link to a robot offers, over HTTP or over a ROS graph
(:mod:`cyborg.client.ros`).
"""

from __future__ import annotations

import contextlib
import json
import urllib.error
import urllib.request
from collections.abc import Callable
from typing import Any, Protocol

from cyborg.errors import CyborgError
from cyborg.web.access import DEFAULT_PORT, TOKEN_ENV, client_headers

__all__ = ["DEFAULT_URL", "ClientError", "HttpLink", "RobotLink"]

DEFAULT_URL = f"http://127.0.0.1:{DEFAULT_PORT}"


class ClientError(CyborgError):
    """A request to a running robot failed: it did not answer, or refused (the message says which)."""


def _request(base: str, path: str, body: dict[str, Any] | None = None, token: str | None = None) -> Any:
    url = base.rstrip("/") + path
    data = None if body is None else json.dumps(body).encode()
    headers = {"Content-Type": "application/json", **client_headers(token)}
    request = urllib.request.Request(url, data=data, headers=headers)
    try:
        with urllib.request.urlopen(request, timeout=5) as response:
            return json.loads(response.read())
    except urllib.error.HTTPError as exc:
        try:
            problem = json.loads(exc.read()).get("error", exc.reason)
        except (json.JSONDecodeError, AttributeError):
            problem = exc.reason
        raise ClientError(f"the robot refused: {problem}") from None
    except (urllib.error.URLError, ConnectionError, TimeoutError) as exc:
        raise ClientError(
            f"no robot answers at {base} ({getattr(exc, 'reason', exc)}); "
            "fix: start one with `cyborg sim`, or pass --url"
        ) from None


def _warning(answer: Any) -> str | None:
    """The robot's warning in a command's answer (e.g. that it cannot save its data), if any."""
    warning = answer.get("warning") if isinstance(answer, dict) else None
    return warning if isinstance(warning, str) else None


class HttpLink:
    """The robot's local HTTP API (``cyborg sim``, or the ``cyborg_api`` ROS node)."""

    def __init__(self, url: str, token: str | None = None) -> None:
        self.url = url
        self.token = token

    def close(self) -> None:
        pass

    def _call(self, path: str, body: dict[str, Any] | None = None) -> Any:
        return _request(self.url, path, body, self.token)

    def send_event(self, name: str) -> bool | None:
        answer = self._call("/api/event", {"name": name})
        return answer.get("is_transition") if isinstance(answer, dict) else None

    def say(self, text: str) -> None:
        self._call("/api/say", {"text": text})

    def set_emotion(self, name: str) -> tuple[str, str | None]:
        answer = self._call("/api/emotion/set", {"name": name})
        emotion = answer.get("emotion") if isinstance(answer, dict) else None
        return (emotion if isinstance(emotion, str) else name), _warning(answer)

    def set_values(self, pleasure: float, arousal: float, dominance: float) -> str | None:
        body = {"pleasure": pleasure, "arousal": arousal, "dominance": dominance}
        return _warning(self._call("/api/emotion/values", body))

    def switch(self, on: bool) -> str | None:
        return _warning(self._call("/api/emotion/switch", {"on": on}))

    def status(self) -> dict[str, Any]:
        answer: dict[str, Any] = self._call("/api/status")
        return answer

    def follow(self, status: dict[str, Any], show: Callable[[dict[str, Any]], None]) -> None:
        import asyncio

        import aiohttp

        try:
            with contextlib.suppress(KeyboardInterrupt):
                asyncio.run(_follow(self.url, status, show, self.token))
        except aiohttp.WSServerHandshakeError as exc:
            fix = f"pass --token or set ${TOKEN_ENV}" if exc.status == 401 else "check --url"
            raise ClientError(f"the robot refused its live stream (HTTP {exc.status}); fix: {fix}") from None
        except aiohttp.ClientError as exc:
            raise ClientError(
                f"cannot reach the live stream of the robot at {self.url} ({exc}); fix: check that it runs"
            ) from None


class RobotLink(Protocol):
    """What the commands need of a robot: the HTTP API by default, the ROS graph with --ros/--ros2."""

    def close(self) -> None: ...
    def send_event(self, name: str) -> bool | None: ...
    def say(self, text: str) -> None: ...
    def set_emotion(self, name: str) -> tuple[str, str | None]:
        """The emotion the robot calls ``name`` (an alias names its emotion), and any warning."""

    def set_values(self, pleasure: float, arousal: float, dominance: float) -> str | None: ...
    def switch(self, on: bool) -> str | None: ...
    def status(self) -> dict[str, Any]: ...
    def follow(self, status: dict[str, Any], show: Callable[[dict[str, Any]], None]) -> None: ...


async def _follow(
    url: str, status: dict[str, Any], show: Callable[[dict[str, Any]], None], token: str | None = None
) -> None:
    import aiohttp

    ws_url = url.rstrip("/").replace("http", "ws", 1) + "/api/ws"
    headers = client_headers(token)
    async with aiohttp.ClientSession() as session, session.ws_connect(ws_url, headers=headers) as socket:
        async for message in socket:
            if message.type != aiohttp.WSMsgType.TEXT:
                break
            record = json.loads(message.data)
            kind = record.get("type")
            if kind == "state":
                status.update(previous_state=record["from"], event=record["event"], state=record["to"])
            elif kind == "emotion":
                status.update({k: record[k] for k in ("emotion", "pleasure", "arousal", "dominance")})
            else:
                continue
            show(status)
        code = socket.close_code
    # The stream ended without a Ctrl-C: the robot went away; say so (and exit non-zero).
    if code == aiohttp.WSCloseCode.GOING_AWAY:
        raise ClientError(f"the robot at {url} stopped (it closed its live stream)")
    raise ClientError(
        f"lost the live stream of the robot at {url} (close code {code}); fix: check that it still runs"
    )
