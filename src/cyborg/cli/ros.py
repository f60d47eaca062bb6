"""``cyborg node`` and ``cyborg launch``: the robot over ROS 1 (ROS 2 with ``--ros2``), a process a part.

The options become one :class:`~cyborg.run.node.NodeOptions` (or a
:class:`~cyborg.run.supervisor.Launch`) and a :class:`~cyborg.run.middleware.Middleware`;
how the nodes run is :mod:`cyborg.run`'s.
"""

from __future__ import annotations

import os
import sys
import time
import traceback
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import click

from cyborg.cli.common import (
    access_options,
    check_factor,
    check_modules,
    check_port,
    config_option,
    data_dir_option,
    duration_option,
    fail,
    load_or_default,
    map_option,
    parse_speed,
    ros2_option,
)
from cyborg.cli.recording import record_options, recorder_settings
from cyborg.errors import CyborgError
from cyborg.web.access import Access

if TYPE_CHECKING:
    from cyborg.app.config import LoadedConfig
    from cyborg.app.sketch import ConfigSketch
    from cyborg.run.middleware import Middleware
    from cyborg.run.scenario import ScenarioFiles

_speed_help = "virtual time at this factor of real time (all nodes share one clock); default real time"


@click.command("node")
@click.argument("name")
@config_option
@data_dir_option()
@map_option
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
    "--lockstep",
    "lockstep",
    default=None,
    metavar="HOST:PORT",
    help="virtual time granted by the lockstep time server of `cyborg launch --speed max` (instead of --speed)",
)
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
    "--with",
    "also",
    multiple=True,
    metavar="NAME",
    help="ROS 2: host this module or gatekeeper (or, beside cyborg_api, cyborg_recorder) in the same "
    "process, as its own node (repeatable; `cyborg launch --ros2` shares a process among the thin "
    "modules, and another between the API and the recorder)",
)
@click.option(
    "--checked",
    default=None,
    metavar="DIGEST",
    hidden=True,
    help="set by `cyborg launch`: the digest of the configuration text it validated; a module's or "
    "gatekeeper's node then reads only its own part of the file (validated whole when it changed)",
)
@ros2_option("a ROS 2 node (rclpy, .venv-ros2; no master), with use_sim_time under --speed")
@access_options
@record_options
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
    lockstep: str | None,
    publish_clock: bool | None,
    script_path: Path | None,
    transcript_path: Path | None,
    fresh: bool,
    also: tuple[str, ...],
    checked: str | None,
    middleware: Middleware,
    access: Access,
    record_path: Path | None,
    no_record: bool,
) -> None:
    """Run one part of the robot as the ROS 1 node NAME (cyborg_controller, a module, a gatekeeper,
    cyborg_recorder, cyborg_api, or cyborg_scenario with --script); with --ros2 as a ROS 2 node."""
    try:
        middleware.enter()  # ROS 2 from the main venv: returns only in a Python that has rclpy
    except CyborgError as exc:
        fail(exc)
    from cyborg.app.parts import RECORDER
    from cyborg.run.census import NAME_TAKEN_EXIT, NameTaken
    from cyborg.run.datadir import default_data_dir
    from cyborg.run.node import ApiOptions, NodeOptions, run_node
    from cyborg.run.simtime import SimTime

    if speed is not None and speed <= 0:
        raise click.BadParameter(f"{speed!r} must be positive", param_hint="--speed")
    sim_time = SimTime(speed=speed, epoch=parse_epoch(epoch), start=parse_start(start_at), lockstep=lockstep)
    try:
        record = None
        if RECORDER in (name, *also):
            whole = load_or_default(config_path)
            # the recorder node records even when the configuration's recording is off: it was asked for
            record = recorder_settings(whole, record_path, no_record, data_dir, enabled=True)
            config: LoadedConfig | ConfigSketch = whole
        else:
            config = _node_config([name, *also], config_path, checked)
        options = NodeOptions(
            # the part checks its own module's settings, loading only its kind
            config=config,
            data_dir=data_dir or default_data_dir(),
            map_path=map_path,
            seed=seed,
            resume=not fresh,
            time=sim_time,
            publish_clock=publish_clock,
            api=ApiOptions(host=host, port=port, access=access),
            scenario=_scenario_files(script_path, transcript_path),
            record=record,
            also=also,
        )
        code = run_node(name, options, middleware)
    except NameTaken as exc:
        click.secho(f"node {name} refused to start: {exc}", fg="red", err=True)
        sys.exit(NAME_TAKEN_EXIT)  # a launch stops the robot instead of starting the node again
    except CyborgError as exc:
        fail(exc)
        return
    if code:
        sys.exit(code)


def _node_config(names: list[str], path: Path | None, checked: str | None) -> LoadedConfig | ConfigSketch:
    """The configuration a process of parts ``names`` builds from: a sketch of it when the launch
    validated this very text and each is a module or gatekeeper (no configuration models
    loaded), else the whole file, validated."""
    if checked is not None and path is not None:
        from cyborg.app.sketch import read_sketch

        sketch = read_sketch(path, checked)
        if sketch is not None and all(sketch.has_part(name) for name in names):
            return sketch
    return load_or_default(path)


def _scenario_files(script: Path | None, transcript: Path | None) -> ScenarioFiles | None:
    if script is None:
        return None
    from cyborg.run.scenario import ScenarioFiles

    return ScenarioFiles(script, transcript)


@click.command("launch")
@config_option
@data_dir_option()
@map_option
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
    "--speed",
    default=None,
    help=_speed_help + ", or 'max': as fast as every node allows, in lockstep; sets /use_sim_time",
)
@click.option("--start", "start_at", default=None, help="with --speed: virtual start, ISO date-time (UTC)")
@ros2_option(
    "ROS 2 nodes (rclpy, .venv-ros2): no master is started; with --speed each node sets use_sim_time"
)
@click.option(
    "--processes",
    type=click.Choice(["shared", "per-part"]),
    default=None,
    help="shared: the thin modules and the gatekeepers share one process, the API and the recorder "
    "another, each its own node (ROS 2 only; its default); per-part: a process per part (ROS 1's only way: rospy runs one "
    "node per process)",
)
@click.option(
    "--fork/--no-fork",
    default=True,
    show_default=True,
    help="fork the node processes from one that imported what they all import (shared memory, a faster "
    "start); --no-fork starts each afresh",
)
@duration_option
@record_options
def launch_command(
    config_path: Path | None,
    data_dir: Path | None,
    map_path: Path | None,
    port: int,
    only: tuple[str, ...],
    write_path: Path | None,
    speed: str | None,
    start_at: str | None,
    middleware: Middleware,
    duration: float | None,
    record_path: Path | None,
    no_record: bool,
    processes: str | None,
    fork: bool,
) -> None:
    """Start the whole robot over ROS 1 (a master if none runs) or ROS 2 (--ros2), a node a part (see --processes).

    With --speed N every node runs in virtual time at N times real time from one shared origin,
    /use_sim_time is set and the simulated base publishes /clock. With --speed max the time moves
    in lockstep: to the next timer of any node once every node is idle and every message sent has
    arrived, so a run is as fast as its work and repeats exactly. With --ros2 the parts are ROS 2
    nodes (no master; each node's use_sim_time parameter is set instead). The cyborg_recorder node
    records the run to MCAP (--record FILE.mcap names the file; --no-record: no recorder node).
    """
    from cyborg.app.parts import RECORDER
    from cyborg.run.datadir import default_data_dir
    from cyborg.run.middleware import ROS1
    from cyborg.run.roslaunch import all_parts, roslaunch_xml, with_recorder
    from cyborg.run.supervisor import Launch, launch, start_zygote

    parsed = parse_speed(speed)
    lockstep = parsed is None
    factor = None if parsed is None or parsed == "real" else float(parsed)
    start = parse_start(start_at)

    zygote = None
    try:
        if fork and write_path is None:  # it imports what the nodes import while this validates the file
            zygote = start_zygote(middleware)
        config = load_or_default(config_path)
        _check_modules_apart(config)
        path = Path(config.source).resolve()
        parts = list(only) or all_parts(config)
        unknown = sorted(set(parts) - set(all_parts(config)))
        if unknown:
            raise CyborgError(
                f"no part called {', '.join(unknown)}; fix: use one of {', '.join(all_parts(config))}"
            )
        if no_record and record_path is not None:
            raise click.UsageError("--record and --no-record exclude each other: pick one")
        parts, extra = with_recorder(parts, record_path, no_record, default=RECORDER in parts)
        folder = (data_dir or default_data_dir()).resolve()
        if write_path is not None:
            if middleware is not ROS1:
                raise click.UsageError("--write writes a ROS 1 roslaunch file; drop --ros2 or --write")
            if speed is not None:
                raise click.UsageError(
                    "--speed needs `cyborg launch` itself (it fixes the nodes' shared origin); drop --write"
                )
            write_path.write_text(roslaunch_xml(path, parts, folder), encoding="utf-8")
            click.echo(f"wrote {write_path}")
            return
        robot = Launch(
            path,
            config,
            parts,
            folder,
            map_path,
            port,
            speed=factor,
            lockstep=lockstep,
            start=start,
            middleware=middleware,
            extra_args=extra,
            hosts=_shared_processes(processes, middleware, config, parts),
            fork=fork,
            zygote=zygote,
        )
        zygote = None  # the launch's now: it ends it
        launch(robot, duration=duration)
    except CyborgError as exc:
        fail(exc)
    finally:
        if zygote is not None:  # the launch never started
            zygote.close(at_once=True)


def _check_modules_apart(config: LoadedConfig) -> None:
    """:func:`check_modules` in a forked child: the module kinds it imports to check their settings
    (the simulated base's scipy, the navigation's database, ~35 MB) stay out of the launcher,
    which runs as long as the robot."""
    if not hasattr(os, "fork"):
        check_modules(config)
        return
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # (the launcher is single-threaded here: nothing started yet)
        code = 1
        try:
            check_modules(config)
            code = 0
        except CyborgError as exc:
            click.secho(str(exc), fg="red", err=True)
        except BaseException:
            traceback.print_exc()
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(1)


def _shared_processes(
    choice: str | None,
    middleware: Middleware,
    config: LoadedConfig,
    parts: list[str],
) -> dict[str, list[str]]:
    """``--processes``: shared by default where a process may hold many nodes (ROS 2)."""
    from cyborg.run.supervisor import shared_process

    if choice == "shared" and not middleware.hosts_many:
        raise click.UsageError(
            f"--processes shared: {middleware.name} runs one node per process (rospy), and a gatekeeper "
            "tells modules apart by their process's node name; fix: drop it, or add --ros2"
        )
    if choice == "per-part" or not middleware.hosts_many:
        return {}
    return shared_process(config, parts)


def parse_epoch(value: str | None) -> float | str | None:
    """``--epoch``: Unix seconds (``1795424400.5``), ``param:/cyborg_sim/RUN`` or ``dir:FOLDER``."""
    from cyborg.run.simtime import EPOCH_DIR_PREFIX, EPOCH_PARAM_PREFIX

    if value is None or value.startswith((EPOCH_PARAM_PREFIX, EPOCH_DIR_PREFIX)):
        return value
    try:
        return float(value)
    except ValueError:
        raise click.BadParameter(
            f"{value!r} is neither a time in Unix seconds (e.g. {time.time():.1f}) nor param:NAMESPACE "
            "nor dir:FOLDER"
        ) from None


def parse_start(value: str | None) -> datetime:
    """``--start``: an ISO date-time (UTC unless it says otherwise); default the simulator's usual start."""
    from cyborg.transport.clock import DEFAULT_VIRTUAL_START

    if value is None:
        return DEFAULT_VIRTUAL_START
    try:
        moment = datetime.fromisoformat(value)
    except ValueError:
        raise click.BadParameter(f"{value!r} is not an ISO date-time, e.g. 2026-11-23T15:29:00") from None
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)
