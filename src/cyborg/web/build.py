"""The one assembly of the HTTP API and dashboard, for the in-process robot and the ``cyborg_api`` node.

:func:`build_api` makes the :class:`~cyborg.web.api.RobotAPI` of a robot's configuration on a
node and lets every extension (the dashboard) add its routes, reading the robot through a
:class:`~cyborg.app.view.RobotView`: the in-process :class:`~cyborg.app.robot.Robot`, or the
mirror a ROS node reads over the graph (:mod:`cyborg.web.ros_view`). :func:`start_api` serves
it and announces the address; :func:`serve_api` is the in-process robot's hook.
"""

from __future__ import annotations

import socket
from collections.abc import Awaitable, Callable
from typing import Any

from cyborg.app.config import LoadedConfig
from cyborg.app.robot import Robot
from cyborg.app.view import RobotView
from cyborg.errors import CyborgError
from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.transport.base import Node, Transport
from cyborg.web.access import Access, announcement
from cyborg.web.api import RobotAPI
from cyborg.web.dashboard import register as register_dashboard
from cyborg.web.lookback import register as register_lookback

__all__ = ["EXTENSIONS", "IN_PROCESS_GRAPH", "build_api", "serve_api", "start_api"]

IN_PROCESS_GRAPH = "in this process (no ROS graph)"
"""The status's ``graph`` of the in-process robot (a ROS node's names its domain or master)."""

Stop = Callable[[], Awaitable[None]]

EXTENSIONS: list[Callable[[RobotAPI, RobotView], None]] = [register_dashboard, register_lookback]
"""Functions that add routes to the API of a robot (the dashboard and its look back at the
recording register themselves here)."""


def build_api(
    node: Node,
    config: LoadedConfig,
    view: RobotView,
    *,
    access: Access | None = None,
    extra_status: Callable[[], dict[str, Any]] | None = None,
    settle: Callable[[], None] | None = None,
) -> RobotAPI:
    """The API of the robot ``view`` shows (built from ``config``), served by ``node``, with every
    extension's routes. ``extra_status``: more fields of ``/api/status``; ``settle``: waits until
    what the robot saves is written (see :class:`RobotAPI`)."""
    api = RobotAPI(
        node,
        machine=config.machine,
        emotions=dict(config.model.emotion.prototypes),
        emotion_aliases=config.model.emotion.usable_aliases(),
        extra_status=extra_status,
        settle=settle,
        access=access,
    )
    for extend in EXTENSIONS:
        extend(api, view)
    return api


async def start_api(
    api: RobotAPI, host: str, port: int, say: Callable[[str, str], None], *, token_given: bool
) -> str:
    """Serve ``api`` on ``host:port`` and announce where (and the token, beyond loopback) with
    ``say(text, colour)``; return the address."""
    try:
        url = await api.start(host, port)
    except socket.gaierror as exc:  # the host is the problem, not the port
        raise CyborgError(
            f"cannot serve on {host}:{port}: {exc.strerror}; fix: give --host an address of this machine "
            "(127.0.0.1 for this machine only, 0.0.0.0 for every network it is on)"
        ) from exc
    except OSError as exc:
        raise CyborgError(
            f"cannot serve on {host}:{port}: {exc.strerror}; fix: pass --port 0 or another port"
        ) from exc
    for text, colour in announcement(url, host, api.port or port, api.token, generated=not token_given):
        say(text, colour)
    return url


def serve_api(
    host: str, port: int, say: Callable[..., Any], access: Access | None = None
) -> Callable[[Transport, Robot], Awaitable[Stop]]:
    """A ``serve`` hook for :func:`cyborg.run.local.run_sim` that starts the HTTP API.

    ``access``: the token and extra origins (see :mod:`cyborg.web.security`); beyond
    loopback a token is made if none is given, and printed with the address.
    """
    access = access or Access()
    given = access.token is not None

    async def serve(transport: Transport, robot: Robot) -> Stop:
        gatekeepers = {name: c for name, c in robot.components.items() if isinstance(c, Gatekeeper)}
        api = build_api(
            transport.node("cyborg_api"),
            robot.config,
            robot,
            access=access,
            extra_status=lambda: {
                "gatekeepers": {name: g.report() for name, g in gatekeepers.items()},
                "emotion_enabled": robot.emotion.enabled,
                "storage": robot.store.save_status.as_json(),
                "blocked": robot.loop_blocked(),
                "graph": IN_PROCESS_GRAPH,
            },
            settle=robot.store.flush,
        )
        await start_api(api, host, port, lambda text, colour: say(text, fg=colour), token_given=given)
        return api.stop

    return serve
