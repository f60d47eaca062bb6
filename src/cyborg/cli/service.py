"""``cyborg service install|status|uninstall``: the robot started at boot by systemd
(:mod:`cyborg.run.service`)."""

from __future__ import annotations

import getpass
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click

from cyborg.cli.common import check_port, config_option, data_dir_option, fail, load_or_default, ros2_option
from cyborg.errors import CyborgError

if TYPE_CHECKING:
    from cyborg.run.middleware import Middleware

_user_help = "a user unit (~/.config/systemd/user; runs while you are logged in, or always after `loginctl enable-linger`)"


@click.group("service")
def service_group() -> None:
    """Start the robot when the computer boots: install, status or uninstall a systemd unit.

    The unit runs `cyborg launch` (docs/robot.md)."""


@service_group.command("install")
@config_option
@data_dir_option()
@ros2_option("launch the robot over ROS 2 (default ROS 1)")
@click.option(
    "--port", default=8642, show_default=True, type=int, callback=check_port, help="port of the dashboard"
)
@click.option("--user", "user_unit", is_flag=True, help=_user_help)
@click.option("--no-start", is_flag=True, help="enable it for the next boot, but do not start it now")
@click.option(
    "--write",
    "write_path",
    type=click.Path(path_type=Path),
    help="only write the unit to this file (to read or check it, e.g. with systemd-analyze verify)",
)
def install(
    config_path: Path | None,
    data_dir: Path | None,
    middleware: Middleware,
    port: int,
    user_unit: bool,
    no_start: bool,
    write_path: Path | None,
) -> None:
    """Write the systemd unit that runs `cyborg launch` with this configuration, enable and start it.

    The unit carries this shell's ROS variables (ROS_MASTER_URI, ROS_IP, ROS_DOMAIN_ID, ...):
    set them as the robot needs them first. It restarts the robot when it fails and logs to
    the journal (`journalctl -u cyborg`)."""
    from cyborg.run.datadir import default_data_dir
    from cyborg.run.service import Service, carried_environment, launch_command, require_systemd, unit_text

    try:
        config = load_or_default(config_path)
        folder = data_dir or default_data_dir()
        owner = None if user_unit else (os.environ.get("SUDO_USER") or getpass.getuser())
        text = unit_text(
            launch_command(Path(config.source), folder, middleware, port),
            environment=carried_environment(folder),
            user=owner,
        )
        if write_path is not None:
            write_path.write_text(text, encoding="utf-8")
            click.echo(f"wrote {write_path}")
            return
        require_systemd()
        service = Service(user=user_unit)
        service.install(text, start=not no_start)
    except CyborgError as exc:
        fail(exc)
        return
    except OSError as exc:
        fail(CyborgError(f"cannot write the unit: {exc}; fix: give a writable path"))
        return
    where = "--user " if user_unit else ""
    click.echo(f"installed {service.path}: the robot starts at boot" + ("" if no_start else ", and now"))
    click.echo(
        f"its log: journalctl {'--user-unit' if user_unit else '-u'} cyborg -f; "
        f"check it: cyborg service status {where}".rstrip()
    )


@service_group.command("status")
@click.option("--user", "user_unit", is_flag=True, help="the user unit")
def status(user_unit: bool) -> None:
    """Whether the robot's unit runs, with its last log lines; exit 0 only when it is active."""
    from cyborg.run.service import Service

    try:
        active, text = Service(user=user_unit).status()
    except CyborgError as exc:
        fail(exc)
        return
    click.echo(text)
    sys.exit(0 if active else 3)  # 3: as `systemctl status` for a unit that is not active


@service_group.command("uninstall")
@click.option("--user", "user_unit", is_flag=True, help="the user unit")
def uninstall(user_unit: bool) -> None:
    """Stop the robot's unit, disable it and remove it."""
    from cyborg.run.service import Service

    service = Service(user=user_unit)
    try:
        removed = service.uninstall()
    except CyborgError as exc:
        fail(exc)
        return
    click.echo(f"removed {service.path}" if removed else f"nothing to remove: {service.path} is not there")
