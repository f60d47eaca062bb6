"""The command tool: talk to a running ``cyborg sim`` through its local HTTP API.

``cyborg event NAME``, ``cyborg say TEXT``, ``cyborg emotion set NAME``,
``cyborg emotion values P A D``, ``cyborg emotion on|off`` and
``cyborg status [--follow]`` (thesis 1.4 and 10.1).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import sys
import urllib.error
import urllib.request
from typing import Any

import click

from cyborg.interfaces.api import DEFAULT_PORT

DEFAULT_URL = f"http://127.0.0.1:{DEFAULT_PORT}"


class ToolError(click.ClickException):
    pass


def _request(base: str, path: str, body: dict[str, Any] | None = None) -> Any:
    url = base.rstrip("/") + path
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(url, data=data, headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=5) as response:
            return json.loads(response.read())
    except urllib.error.HTTPError as exc:
        try:
            problem = json.loads(exc.read()).get("error", exc.reason)
        except (json.JSONDecodeError, AttributeError):
            problem = exc.reason
        raise ToolError(f"the robot refused: {problem}") from None
    except (urllib.error.URLError, ConnectionError, TimeoutError) as exc:
        raise ToolError(
            f"no robot answers at {base} ({getattr(exc, 'reason', exc)}); "
            "fix: start one with `cyborg sim`, or pass --url"
        ) from None


url_option = click.option(
    "--url", default=DEFAULT_URL, show_default=True, envvar="CYBORG_URL", help="the running robot's API"
)


def format_status(status: dict[str, Any]) -> str:
    return (
        f"{status.get('previous_state') or '-'} --{status.get('event') or '-'}--> {status.get('state') or '-'}   "
        f"emotion {status.get('emotion')} (P {status.get('pleasure', 0):+.2f} "
        f"A {status.get('arousal', 0):+.2f} D {status.get('dominance', 0):+.2f})"
    )


@click.command("event")
@click.argument("name")
@url_option
def event_command(name: str, url: str) -> None:
    """Send event NAME to the controller."""
    answer = _request(url, "/api/event", {"name": name})
    note = (
        ""
        if answer.get("is_transition") in (True, None)
        else " (not a transition of the current state: it will be dropped)"
    )
    click.echo(f"sent event {name}{note}")


@click.command("say")
@click.argument("text", nargs=-1, required=True)
@url_option
def say_command(text: tuple[str, ...], url: str) -> None:
    """Send TEXT as if speech-to-text heard it."""
    sentence = " ".join(text)
    _request(url, "/api/say", {"text": sentence})
    click.echo(f"heard: {sentence}")


@click.group("emotion")
def emotion_group() -> None:
    """Set the robot's emotion, its PAD values, or switch the emotion system on/off."""


@emotion_group.command("set")
@click.argument("name")
@url_option
def emotion_set(name: str, url: str) -> None:
    _request(url, "/api/emotion/set", {"name": name})
    click.echo(f"emotion set to {name}")


@emotion_group.command("values")
@click.argument("pleasure", type=float)
@click.argument("arousal", type=float)
@click.argument("dominance", type=float)
@url_option
def emotion_values(pleasure: float, arousal: float, dominance: float, url: str) -> None:
    _request(url, "/api/emotion/values", {"pleasure": pleasure, "arousal": arousal, "dominance": dominance})
    click.echo(f"PAD set to ({pleasure:+.2f}, {arousal:+.2f}, {dominance:+.2f})")


@emotion_group.command("on")
@url_option
def emotion_on(url: str) -> None:
    _request(url, "/api/emotion/switch", {"on": True})
    click.echo("emotion system on")


@emotion_group.command("off")
@url_option
def emotion_off(url: str) -> None:
    _request(url, "/api/emotion/switch", {"on": False})
    click.echo("emotion system off (feedback is ignored)")


@click.command("status")
@click.option("--follow", "-f", is_flag=True, help="keep printing as the robot changes")
@url_option
def status_command(follow: bool, url: str) -> None:
    """Show the previous state, event, current state, emotion and PAD values."""
    status = _request(url, "/api/status")
    click.echo(format_status(status))
    if follow:
        with contextlib.suppress(KeyboardInterrupt):
            asyncio.run(_follow(url, status))


async def _follow(url: str, status: dict[str, Any]) -> None:
    import aiohttp

    ws_url = url.rstrip("/").replace("http", "ws", 1) + "/api/ws"
    async with aiohttp.ClientSession() as session, session.ws_connect(ws_url) as socket:
        async for message in socket:
            record = json.loads(message.data)
            kind = record.get("type")
            if kind == "state":
                status.update(previous_state=record["from"], event=record["event"], state=record["to"])
            elif kind == "emotion":
                status.update({k: record[k] for k in ("emotion", "pleasure", "arousal", "dominance")})
            else:
                continue
            click.echo(format_status(status))
            sys.stdout.flush()


COMMANDS = [event_command, say_command, emotion_group, status_command]
