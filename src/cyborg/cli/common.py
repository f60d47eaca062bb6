"""What the commands of the ``cyborg`` command line share: loading a configuration, failing with
a readable message, and checking option values before anything starts.

Light on purpose (click only): ``cyborg --help`` and the command tool import it.
"""

from __future__ import annotations

import errno
import functools
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from cyborg.errors import CyborgError
from cyborg.limits import MAX_SCRIPT_SECONDS, MAX_SPEED
from cyborg.web.access import TOKEN_ENV, Access, allowed_origins

if TYPE_CHECKING:
    from cyborg.app.config import LoadedConfig
    from cyborg.run.middleware import Middleware

DEFAULT_CONFIG = "cyborg.yaml"


def load_config(path: Path) -> LoadedConfig:
    """:func:`cyborg.app.config.load_config`, imported by the commands that read a configuration."""
    from cyborg.app.config import load_config as load

    return load(path)


def load_or_default(path: Path | None) -> LoadedConfig:
    """The configuration at ``path``, else the packaged Cyborg's (the demo when that is missing).

    A bare name that is no file here (``robot``, ``cyborg``, ``demo``) is the packaged
    configuration of that name (:func:`resolve_config`)."""
    from cyborg.app.config import packaged_config

    if path is None:
        path = packaged_config(DEFAULT_CONFIG)
        if not path.exists():
            path = packaged_config("demo.yaml")
    return load_config(resolve_config(path))


def resolve_config(path: Path) -> Path:
    """``path``, or the packaged ``NAME.yaml`` when ``path`` is a bare NAME that is no file here."""
    from cyborg.app.config import packaged_config

    if path.exists() or len(path.parts) != 1 or path.suffix:
        return path
    shipped = packaged_config(f"{path.name}.yaml")
    return shipped if shipped.exists() else path


def check_modules(loaded: LoadedConfig) -> None:
    """Validate the ``modules:`` section against the installed module kinds."""
    from cyborg.app.registry import module_kinds

    module_kinds().check(loaded.model.modules, source=loaded.source)


def fail(exc: CyborgError) -> None:
    click.secho(str(exc), fg="red", err=True)
    sys.exit(1)


def parse_speed(value: str | None) -> float | str | None:
    if value is None:
        return "real"
    if value == "max":
        return None
    try:
        speed = float(value)
    except ValueError:
        raise click.BadParameter(f"{value!r} is not a number; use e.g. --speed 10 or --speed max") from None
    if not math.isfinite(speed) or speed > MAX_SPEED:
        raise click.BadParameter(
            f"{value!r} is not a usable factor (at most {MAX_SPEED:g}); fix: use e.g. --speed 10, "
            "or --speed max for as fast as possible",
            param_hint="--speed",
        )
    if speed <= 0:
        raise click.BadParameter(f"{value!r} must be positive")
    return speed


def check_port(ctx: click.Context, param: click.Parameter, value: int) -> int:
    if not 0 <= value <= 65535:
        raise click.BadParameter(f"{value} is not a TCP port; fix: use 1-65535, or 0 for any free port")
    return value


def check_duration(ctx: click.Context, param: click.Parameter, value: float | None) -> float | None:
    if value is None:
        return None
    if not (math.isfinite(value) and 0 <= value <= MAX_SCRIPT_SECONDS):
        raise click.BadParameter(
            f"{value!r} is not a duration; fix: give seconds from 0 to {MAX_SCRIPT_SECONDS:.0f} (a year), "
            "or leave --duration out to run until stopped"
        )
    return value


def check_data_folder(ctx: click.Context, param: click.Parameter, value: Path | None) -> Path | None:
    if value is not None and value.exists() and not value.is_dir():
        raise click.BadParameter(
            f"{value} is a file, not a folder; fix: give a folder for the databases (it is made if missing)"
        )
    return value


config_option = click.option(
    "--config",
    "config_path",
    type=click.Path(path_type=Path),
    help="state machine YAML, or a packaged one by name: cyborg (the default, simulated), robot "
    "(the real Cyborg), demo",
)
"""``--config FILE``: the robot's configuration (the command receives ``config_path``)."""

map_option = click.option(
    "--map",
    "map_path",
    type=click.Path(path_type=Path),
    help="map for the simulated base: ARNL .map or map_server .yaml",
)
"""``--map FILE``: the world's map (the command receives ``map_path``)."""


def data_dir_option(
    help: str = "folder of the databases", *, checked: bool = True
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--db``/``--data-dir FOLDER``: where the robot keeps its databases (``data_dir``).

    ``checked``: a file given as the folder is a usage error (exit 2); else the command finds out
    when it opens the folder."""
    return click.option(
        "--db",
        "--data-dir",
        "data_dir",
        type=click.Path(path_type=Path),
        default=None,
        callback=check_data_folder if checked else None,
        help=help,
    )


duration_option = click.option(
    "--duration",
    type=float,
    default=None,
    callback=check_duration,
    help="stop after this many (virtual) seconds",
)


def check_factor(ctx: click.Context, param: click.Parameter, value: float | None) -> float | None:
    if value is not None and not (math.isfinite(value) and value <= MAX_SPEED):
        raise click.BadParameter(
            f"{value!r} is not a usable factor; fix: use e.g. --speed 20 (at most {MAX_SPEED:g})"
        )
    return value


def os_problem(exc: OSError) -> CyborgError:
    """A file system error met while running, as 'what; fix' instead of a traceback."""
    where = f"{exc.filename}: " if exc.filename else ""
    fixes = {
        errno.ENOSPC: "free some space on that disk, or give another folder with --data-dir",
        errno.EDQUOT: "free some space on that disk, or give another folder with --data-dir",
        errno.EACCES: "check the permissions of that path, or use another one",
        errno.EROFS: "that disk is read-only; give a writable folder",
    }
    fix = fixes.get(exc.errno or 0, "check the path")
    return CyborgError(f"{where}{exc.strerror or exc}; fix: {fix}")


def access_options(command: Callable[..., None]) -> Callable[..., None]:
    """``--token`` and ``--allow-origin`` for a command that serves the API; the command receives
    ``access``, an :class:`Access`, instead."""

    def origins(ctx: click.Context, param: click.Parameter, values: tuple[str, ...]) -> tuple[str, ...]:
        try:
            return allowed_origins(values)
        except ValueError as exc:
            raise click.BadParameter(str(exc)) from None

    def token_value(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
        if value is not None and len(value.strip()) < 16:
            raise click.BadParameter(
                "a token shorter than 16 characters is easy to guess; fix: leave it out to get a "
                'generated one, or make one with: python3 -c "import secrets; print(secrets.token_urlsafe(24))"'
            )
        return value.strip() if value else None

    @click.option(
        "--token",
        envvar=TOKEN_ENV,
        callback=token_value,
        help=f"require this bearer token on the API (${TOKEN_ENV}); with a --host beyond loopback one is "
        "generated and printed if not given",
    )
    @click.option(
        "--allow-origin",
        "allow_origin",
        multiple=True,
        callback=origins,
        metavar="URL",
        help="also accept pages and Host names of this origin, e.g. https://cyborg.example:443 (repeatable)",
    )
    @functools.wraps(command)
    def wrapper(*args: Any, token: str | None, allow_origin: tuple[str, ...], **kwargs: Any) -> None:
        command(*args, access=Access(token=token, allowed_origins=allow_origin), **kwargs)

    return wrapper


def middleware_for(wants_ros2: bool) -> Middleware:
    """The middleware a command's ``--ros2`` flag picks: ROS 2 with it, ROS 1 without."""
    from cyborg.run.middleware import ROS1, ROS2

    return ROS2 if wants_ros2 else ROS1


def ros2_option(help: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--ros2``: the command receives ``middleware`` (:func:`middleware_for`) instead of a flag."""
    return click.option(
        "--ros2",
        "middleware",
        is_flag=True,
        callback=lambda ctx, param, value: middleware_for(value),
        help=help,
    )
