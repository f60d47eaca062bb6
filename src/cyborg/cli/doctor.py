"""``cyborg doctor``: one line per check of this machine (and, with ``--ros``/``--ros2``, its ROS
graph) against a configuration; exit 0 only when every check passes. The checks are
:mod:`cyborg.run.doctor`'s."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from cyborg.cli.common import config_option, data_dir_option, fail, load_or_default
from cyborg.errors import CyborgError


@click.command("doctor")
@config_option
@data_dir_option("the robot's data folder to check (default: $CYBORG_DATA_DIR or ~/.local/share/cyborg)")
@click.option("--ros", "graph", flag_value="ros1", help="also check the ROS 1 graph of ROS_MASTER_URI")
@click.option("--ros2", "graph", flag_value="ros2", help="also check the ROS 2 graph of ROS_DOMAIN_ID")
@click.option("--json", "as_json", is_flag=True, help="print the checks as JSON (for scripts)")
def doctor(config_path: Path | None, data_dir: Path | None, graph: str | None, as_json: bool) -> None:
    """Check this machine (and with --ros/--ros2 the running graph) against the configuration.

    One line per check, passed or failed with the fix; exit 0 only when all pass."""
    from cyborg.run.middleware import ROS1, ROS2

    middleware = {"ros1": ROS1, "ros2": ROS2}.get(graph or "")
    if middleware is not None:
        try:
            middleware.enter()  # ROS 2 from the main venv: runs again in .venv-ros2's Python
        except CyborgError as exc:
            fail(exc)
    from cyborg.run.datadir import default_data_dir
    from cyborg.run.doctor import run_doctor

    try:
        config = load_or_default(config_path)
    except CyborgError as exc:
        fail(exc)
        return
    report = run_doctor(config, middleware, (data_dir or default_data_dir()).resolve())
    click.echo(report.to_json() if as_json else report.text())
    sys.exit(0 if report.passed else 1)
