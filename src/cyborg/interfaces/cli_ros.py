"""``cyborg node`` and ``cyborg launch``: the robot over ROS 1 (ROS 2 with ``--ros2``), a process a part."""

from __future__ import annotations

from pathlib import Path

import click

from cyborg.errors import CyborgError
from cyborg.interfaces.access import Access, access_options
from cyborg.interfaces.cli_common import (
    check_data_folder,
    check_factor,
    check_modules,
    check_port,
    duration_option,
    fail,
    load_or_default,
)

_speed_help = "virtual time at this factor of real time (all nodes share one clock); default real time"


@click.command("node")
@click.argument("name")
@click.option(
    "--config",
    "config_path",
    type=click.Path(path_type=Path),
    help="state machine YAML (default: the packaged Cyborg)",
)
@click.option(
    "--db",
    "--data-dir",
    "data_dir",
    type=click.Path(path_type=Path),
    default=None,
    callback=check_data_folder,
    help="folder of the databases",
)
@click.option("--map", "map_path", type=click.Path(path_type=Path), help="map for the simulated base")
@click.option("--host", default="127.0.0.1", show_default=True, help="address of the API (cyborg_api only)")
@click.option(
    "--port",
    default=8642,
    show_default=True,
    type=int,
    callback=check_port,
    help="port of the API (cyborg_api only)",
)
@click.option("--seed", default=0, show_default=True, type=int, help="seed of the node's randomness")
@click.option("--speed", type=float, default=None, callback=check_factor, help=_speed_help)
@click.option(
    "--epoch",
    default=None,
    help="with --speed: wall-clock Unix time at which virtual time reads --start (default: now); "
    "param:NS waits for `cyborg launch` to set NS/epoch",
)
@click.option("--start", "start_at", default=None, help="with --speed: virtual start, ISO date-time (UTC)")
@click.option(
    "--publish-clock/--no-publish-clock",
    default=None,
    help="with --speed: publish /clock (default: when NAME is a simulated base)",
)
@click.option(
    "--script", "script_path", type=click.Path(path_type=Path), help="cyborg_scenario: the script to play"
)
@click.option(
    "--transcript",
    "transcript_path",
    type=click.Path(path_type=Path),
    help="cyborg_scenario: write records here",
)
@click.option(
    "--fresh",
    is_flag=True,
    help="cyborg_controller: start neutral with the emotion system on (as `cyborg launch` does); "
    "without it a controller restarted after a crash resumes an emotion stored within "
    "resume_within_seconds",
)
@click.option(
    "--ros2",
    is_flag=True,
    help="a ROS 2 node (rclpy, .venv-ros2; no master), with use_sim_time under --speed",
)
@access_options
def node(
    name: str,
    config_path: Path | None,
    data_dir: Path | None,
    map_path: Path | None,
    host: str,
    port: int,
    seed: int,
    speed: float | None,
    epoch: str | None,
    start_at: str | None,
    publish_clock: bool | None,
    script_path: Path | None,
    transcript_path: Path | None,
    fresh: bool,
    ros2: bool,
    access: Access,
) -> None:
    """Run one part of the robot as the ROS 1 node NAME (cyborg_controller, a module, a gatekeeper,
    cyborg_api, or cyborg_scenario with --script); with --ros2 as a ROS 2 node."""
    if ros2:
        from cyborg.interfaces.ros2_env import run_in_ros2_venv

        try:
            run_in_ros2_venv()  # returns only in a Python that has rclpy
        except CyborgError as exc:
            fail(exc)
    from cyborg.interfaces.ros_commands import ScenarioFiles, SimTime, parse_epoch, parse_start, run_node
    from cyborg.sim.runner import default_data_dir

    if speed is not None and speed <= 0:
        raise click.BadParameter(f"{speed!r} must be positive", param_hint="--speed")
    sim_time = SimTime(speed=speed, epoch=parse_epoch(epoch), start=parse_start(start_at))
    scenario = ScenarioFiles(script_path, transcript_path) if script_path is not None else None
    try:
        config = load_or_default(
            config_path
        )  # the part checks its own module's settings, loading only its kind
        run_node(
            name,
            config,
            data_dir or default_data_dir(),
            map_path,
            host,
            port,
            seed,
            sim_time=sim_time,
            publish_clock_too=publish_clock,
            scenario=scenario,
            resume=not fresh,
            access=access,
            ros2=ros2,
        )
    except CyborgError as exc:
        fail(exc)


@click.command("launch")
@click.option(
    "--config",
    "config_path",
    type=click.Path(path_type=Path),
    help="state machine YAML (default: the packaged Cyborg)",
)
@click.option(
    "--db",
    "--data-dir",
    "data_dir",
    type=click.Path(path_type=Path),
    default=None,
    callback=check_data_folder,
    help="folder of the databases",
)
@click.option("--map", "map_path", type=click.Path(path_type=Path), help="map for the simulated base")
@click.option(
    "--port", default=8642, show_default=True, type=int, callback=check_port, help="port of the API node"
)
@click.option("--only", multiple=True, help="launch only these parts (repeatable)")
@click.option(
    "--write",
    "write_path",
    type=click.Path(path_type=Path),
    help="write a roslaunch file instead of launching",
)
@click.option(
    "--speed", type=float, default=None, callback=check_factor, help=_speed_help + "; sets /use_sim_time"
)
@click.option("--start", "start_at", default=None, help="with --speed: virtual start, ISO date-time (UTC)")
@click.option(
    "--ros2",
    is_flag=True,
    help="ROS 2 nodes (rclpy, .venv-ros2): no master is started; with --speed each node sets use_sim_time",
)
@duration_option
def launch_command(
    config_path: Path | None,
    data_dir: Path | None,
    map_path: Path | None,
    port: int,
    only: tuple[str, ...],
    write_path: Path | None,
    speed: float | None,
    start_at: str | None,
    ros2: bool,
    duration: float | None,
) -> None:
    """Start the whole robot over ROS 1 (a master if none runs) or ROS 2 (--ros2), a process a part.

    With --speed N every node runs in virtual time at N times real time from one shared origin,
    /use_sim_time is set and the simulated base publishes /clock. With --ros2 the parts are ROS 2
    nodes (no master; each node's use_sim_time parameter is set instead).
    """
    from cyborg.interfaces.ros_commands import parse_start
    from cyborg.interfaces.ros_launch import all_parts, launch, roslaunch_xml
    from cyborg.sim.runner import default_data_dir

    if speed is not None and speed <= 0:
        raise click.BadParameter(f"{speed!r} must be positive", param_hint="--speed")
    start = parse_start(start_at)

    try:
        config = load_or_default(config_path)
        check_modules(config)
        path = Path(config.source).resolve()
        parts = list(only) or all_parts(config)
        unknown = sorted(set(parts) - set(all_parts(config)))
        if unknown:
            raise CyborgError(
                f"no part called {', '.join(unknown)}; fix: use one of {', '.join(all_parts(config))}"
            )
        folder = (data_dir or default_data_dir()).resolve()
        if write_path is not None:
            if ros2:
                raise click.UsageError("--write writes a ROS 1 roslaunch file; drop --ros2 or --write")
            if speed is not None:
                raise click.UsageError(
                    "--speed needs `cyborg launch` itself (it fixes the nodes' shared origin); drop --write"
                )
            write_path.write_text(roslaunch_xml(path, parts, folder), encoding="utf-8")
            click.echo(f"wrote {write_path}")
            return
        launch(
            path,
            config,
            parts,
            folder,
            map_path,
            port,
            echo=True,
            speed=speed,
            start=start,
            duration=duration,
            ros2=ros2,
        )
    except CyborgError as exc:
        fail(exc)
