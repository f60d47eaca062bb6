"""Serve the API (and, once present, the dashboard) next to a running robot."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

from cyborg.app.robot import Robot
from cyborg.errors import CyborgError
from cyborg.interfaces.access import Access, announcement
from cyborg.interfaces.api import RobotAPI
from cyborg.interfaces.dashboard import register as register_dashboard
from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.transport.base import Transport

Stop = Callable[[], Awaitable[None]]

# Functions that add routes to the API for a robot (the dashboard registers itself here).
EXTENSIONS: list[Callable[[RobotAPI, Robot], None]] = [register_dashboard]


def serve_api(
    host: str, port: int, say: Callable[..., Any], access: Access | None = None
) -> Callable[[Transport, Robot], Awaitable[Stop]]:
    """A ``serve`` hook for :func:`cyborg.sim.runner.run_sim` that starts the HTTP API.

    ``access``: the token and extra origins (see :mod:`cyborg.interfaces.security`); beyond
    loopback a token is made if none is given, and printed with the address.
    """
    access = access or Access()
    given = access.token is not None

    async def serve(transport: Transport, robot: Robot) -> Stop:
        gatekeepers = {name: c for name, c in robot.components.items() if isinstance(c, Gatekeeper)}
        api = RobotAPI(
            transport.node("cyborg_api"),
            machine=robot.config.machine,
            emotions=dict(robot.config.model.emotion.prototypes),
            emotion_aliases=robot.config.model.emotion.usable_aliases(),
            extra_status=lambda: {
                "gatekeepers": {name: g.report() for name, g in gatekeepers.items()},
                "emotion_enabled": robot.emotion.enabled,
                "storage": robot.store.save_status.as_json(),
            },
            settle=robot.store.flush,
            access=access,
        )
        for extend in EXTENSIONS:
            extend(api, robot)
        try:
            url = await api.start(host, port)
        except OSError as exc:
            raise CyborgError(
                f"cannot serve on {host}:{port}: {exc.strerror}; fix: pass --port 0 or another port"
            ) from exc
        for text, colour in announcement(url, host, api.port or port, api.token, generated=not given):
            say(text, fg=colour)
        return api.stop

    return serve
