"""The command tool: ``cyborg event``, ``say``, ``emotion`` and ``status`` for a running robot.

``cyborg event NAME``, ``cyborg say TEXT``, ``cyborg emotion set NAME``,
``cyborg emotion values P A D``, ``cyborg emotion on|off`` and ``cyborg status [--follow]``
(thesis 1.4 and 10.1) talk to the robot's local HTTP API (:mod:`cyborg.client.http`); with
``--ros`` (``--ros2``) the same commands go over the ROS 1 (ROS 2) graph instead
(:mod:`cyborg.client.ros`), and ``--ros2`` typed in the main venv runs the command again in
``.venv-ros2``. Light: click and urllib only until a command runs over ROS.
"""

from __future__ import annotations

import functools
import math
import sys
from collections.abc import Callable
from typing import Any

import click

from cyborg.client.http import DEFAULT_URL, HttpLink, RobotLink
from cyborg.errors import CyborgError
from cyborg.web.access import TOKEN_ENV

__all__ = ["COMMANDS", "ToolError", "link_options"]


class ToolError(CyborgError, click.ClickException):
    """A command to the robot failed: printed as 'Error: ...', exit code 1."""


def link_options(command: Callable[..., None]) -> Callable[..., None]:
    """--url, --ros and --ros2; the command receives ``link``, an open :class:`RobotLink`, instead."""

    @click.option(
        "--url", default=DEFAULT_URL, show_default=True, envvar="CYBORG_URL", help="the running robot's API"
    )
    @click.option(
        "--token",
        envvar=TOKEN_ENV,
        help=f"the robot's API token (${TOKEN_ENV}), needed when it serves beyond loopback; "
        "`cyborg sim` prints it at start",
    )
    @click.option(
        "--ros",
        "over_ros",
        is_flag=True,
        envvar="CYBORG_ROS",
        help="talk to a robot of ROS nodes through its topics and services (ROS_MASTER_URI)",
    )
    @click.option(
        "--ros2",
        "over_ros2",
        is_flag=True,
        envvar="CYBORG_ROS2",
        help="talk to a robot of ROS 2 nodes through its topics and services (ROS_DOMAIN_ID)",
    )
    @functools.wraps(command)
    def wrapper(
        *args: Any, url: str, token: str | None, over_ros: bool, over_ros2: bool, **kwargs: Any
    ) -> None:
        link: RobotLink
        if over_ros and over_ros2:
            raise click.UsageError("--ros and --ros2 exclude each other: the robot runs on one of them")
        if over_ros or over_ros2:
            from cyborg.cli.common import middleware_for
            from cyborg.client.ros import RosLink

            middleware = middleware_for(over_ros2)
            try:
                middleware.enter()  # ROS 2 in the main venv: returns only in a Python that has rclpy
                link = RosLink(middleware)
            except CyborgError as exc:
                raise ToolError(str(exc)) from None
        else:
            link = HttpLink(url, token)
        try:
            command(*args, link=link, **kwargs)
        except CyborgError as exc:
            raise ToolError(str(exc)) from None
        finally:
            link.close()

    return wrapper


def format_status(status: dict[str, Any]) -> str:
    enabled = status.get("emotion_enabled")
    switch = "unknown" if enabled is None else "on" if enabled else "OFF (feedback is ignored)"
    line = (
        f"{status.get('previous_state') or '-'} --{status.get('event') or '-'}--> {status.get('state') or '-'}   "
        f"emotion {status.get('emotion')} (P {status.get('pleasure', 0):+.2f} "
        f"A {status.get('arousal', 0):+.2f} D {status.get('dominance', 0):+.2f})   "
        f"emotion system {switch}"
    )
    storage = status.get("storage")
    if isinstance(storage, dict) and storage.get("saved") is False:
        unsaved = " and ".join(storage.get("unsaved") or []) or "its data"
        line += (
            f"\n  NOT SAVED: {storage.get('problem')}; the robot goes on in memory ({unsaved} not saved, "
            f"{storage.get('failed_writes', 0)} failed writes); fix: {storage.get('fix')}"
        )
    return line


def _echo_done(done: str, warning: str | None) -> None:
    click.echo(done)
    if warning:
        click.secho(f"warning: {warning}", fg="yellow", err=True)


def format_gatekeeper(name: str, counts: dict[str, Any]) -> str:
    by_sender = ", ".join(f"{who} {n}" for who, n in sorted((counts.get("dropped_by_sender") or {}).items()))
    return (
        f"  gatekeeper {name} ({counts.get('resource')}, held by {counts.get('held_by') or 'nobody'}): "
        f"passed {counts.get('passed', 0)}, dropped {counts.get('dropped', 0)}"
        + (f" ({by_sender})" if by_sender else "")
    )


@click.command("event")
@click.argument("name")
@link_options
def event_command(name: str, link: RobotLink) -> None:
    """Send event NAME to the controller."""
    is_transition = link.send_event(name)
    note = (
        ""
        if is_transition in (True, None)
        else " (not a transition of the current state: it will be dropped)"
    )
    click.echo(f"sent event {name}{note}")


@click.command("say")
@click.argument("text", nargs=-1, required=True)
@link_options
def say_command(text: tuple[str, ...], link: RobotLink) -> None:
    """Send TEXT as if speech-to-text heard it."""
    sentence = " ".join(text)
    link.say(sentence)
    reached = getattr(link, "delivered_to", None)
    click.echo(f"heard: {sentence}" + (f" (by {', '.join(reached)})" if reached else ""))


@click.group("emotion")
def emotion_group() -> None:
    """Set the robot's emotion, its PAD values, or switch the emotion system on/off."""


@emotion_group.command("set")
@click.argument("name")
@link_options
def emotion_set(name: str, link: RobotLink) -> None:
    """Set the emotion by name (its prototype's PAD values)."""
    emotion, warning = link.set_emotion(name)
    typed = "" if emotion == name else f" (you typed {name})"
    _echo_done(f"emotion set to {emotion}{typed}", warning)


def _pad_value(ctx: click.Context, param: click.Parameter, value: float) -> float:
    if not math.isfinite(value) or abs(value) > 1:
        raise click.BadParameter(f"{value!r} is outside [-1, 1]; PAD values run from -1 to 1")
    return value


@emotion_group.command("values", context_settings={"ignore_unknown_options": True})  # -0.5 is a value
@click.argument("pleasure", type=float, callback=_pad_value)
@click.argument("arousal", type=float, callback=_pad_value)
@click.argument("dominance", type=float, callback=_pad_value)
@link_options
def emotion_values(pleasure: float, arousal: float, dominance: float, link: RobotLink) -> None:
    """Set the PAD values (each in [-1, 1])."""
    warning = link.set_values(pleasure, arousal, dominance)
    _echo_done(f"PAD set to ({pleasure:+.2f}, {arousal:+.2f}, {dominance:+.2f})", warning)


@emotion_group.command("on")
@link_options
def emotion_on(link: RobotLink) -> None:
    """Switch the emotion system on."""
    _echo_done("emotion system on", link.switch(True))


@emotion_group.command("off")
@link_options
def emotion_off(link: RobotLink) -> None:
    """Switch the emotion system off: feedback is ignored until it is on again."""
    _echo_done("emotion system off (feedback is ignored)", link.switch(False))


@click.command("status")
@click.option("--follow", "-f", is_flag=True, help="keep printing as the robot changes")
@link_options
def status_command(follow: bool, link: RobotLink) -> None:
    """Show the previous state, event, current state, emotion and PAD values."""
    status = link.status()
    click.echo(format_status(status))
    for name, counts in (status.get("gatekeepers") or {}).items():
        click.echo(format_gatekeeper(name, counts))
    if follow:
        status.pop("storage", None)  # not on the live stream: shown above, and by `cyborg status` again

        def show(current: dict[str, Any]) -> None:
            click.echo(format_status(current))
            sys.stdout.flush()

        link.follow(status, show)


COMMANDS = [event_command, say_command, emotion_group, status_command]
