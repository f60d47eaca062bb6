"""The ``cyborg`` command line: validate and draw machines, run the simulated robot, tools.

Top of the import chain: it may use every layer below it, but imports each part only in the
command that needs it, so that ``cyborg --help`` and the command tool (``cyborg say``) load
click and an HTTP client only, and ``cyborg node`` only its own part (issue 13).
"""

from __future__ import annotations

import errno
import importlib
import logging
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click

from cyborg.errors import CyborgError
from cyborg.interfaces.access import Access, access_options
from cyborg.limits import MAX_SCRIPT_SECONDS, MAX_SPEED

if TYPE_CHECKING:
    from cyborg.app.config import LoadedConfig

DEFAULT_CONFIG = "cyborg.yaml"


def packaged_config(name: str) -> Path:
    """Path of a configuration file shipped with the package (``src/cyborg/data``)."""
    from importlib import resources

    return Path(str(resources.files("cyborg") / "data" / name))


def load_config(path: Path) -> LoadedConfig:
    """:func:`cyborg.app.config.load_config`, imported by the commands that read a configuration."""
    from cyborg.app.config import load_config as load

    return load(path)


def _load(path: Path | None) -> LoadedConfig:
    if path is None:
        path = packaged_config(DEFAULT_CONFIG)
        if not path.exists():
            path = packaged_config("demo.yaml")
    return load_config(path)


def check_modules(loaded: LoadedConfig) -> None:
    """Validate the ``modules:`` section against the installed module kinds."""
    from cyborg.app.registry import module_kinds

    module_kinds().check(loaded.model.modules, source=loaded.source)


def _fail(exc: CyborgError) -> None:
    click.secho(str(exc), fg="red", err=True)
    sys.exit(1)


class LazyGroup(click.Group):
    """A group whose ``lazy`` subcommands are imported when run or asked for their help; its
    own ``--help`` lists them with the short help given here, without importing them."""

    def __init__(self, *args: object, lazy: dict[str, tuple[str, str]], **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.lazy = lazy  # name -> ("module:attribute", short help)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self.lazy})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in self.lazy and cmd_name not in self.commands:
            module, _, attribute = self.lazy[cmd_name][0].partition(":")
            command = getattr(importlib.import_module(module), attribute)
            assert isinstance(command, click.Command)
            self.add_command(command, cmd_name)
        return super().get_command(ctx, cmd_name)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        names = self.list_commands(ctx)
        limit = formatter.width - 6 - max((len(name) for name in names), default=0)
        rows: list[tuple[str, str]] = []
        for name in names:
            if name in self.lazy and name not in self.commands:
                rows.append((name, click.Command(name, help=self.lazy[name][1]).get_short_help_str(limit)))
                continue
            command = self.get_command(ctx, name)
            if command is not None and not command.hidden:
                rows.append((name, command.get_short_help_str(limit)))
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


@click.group(
    cls=LazyGroup,
    context_settings={"help_option_names": ["-h", "--help"]},
    lazy={
        "db": (
            "cyborg.interfaces.db_cli:db_group",
            "Locations, calendar events and responses of the navigation module.",
        )
    },
)
@click.option(
    "--log-level",
    default="INFO",
    show_default=True,
    type=click.Choice(["DEBUG", "INFO", "WARNING", "ERROR"], case_sensitive=False),
)
def cli(log_level: str) -> None:
    """The NTNU Cyborg's behaviour controller and its simulated robot."""
    logging.basicConfig(
        level=log_level.upper(),
        format="%(asctime)s %(levelname)-7s %(name)s: %(message)s",
        datefmt="%H:%M:%S",
    )


@cli.command()
@click.argument("file", type=click.Path(path_type=Path))
def validate(file: Path) -> None:
    """Check a state machine YAML FILE; exit 0 if valid, 1 with the problems otherwise."""
    try:
        loaded = load_config(file)
        check_modules(loaded)
    except CyborgError as exc:
        _fail(exc)
        return
    for warning in loaded.warnings:
        click.secho(f"warning: {warning}", fg="yellow", err=True)
    leaves = len(loaded.machine.leaves())
    click.echo(f"{file}: valid ({leaves} states, initial {loaded.machine.initial!r})")


@cli.command()
@click.option("--markdown", is_flag=True, help="print each kind's settings as Markdown tables")
def kinds(markdown: bool) -> None:
    """List the module kinds this installation knows (built in or from installed packages)."""
    from cyborg.app.kinds_doc import kinds_markdown
    from cyborg.app.registry import module_kinds

    registry = module_kinds()
    try:
        if markdown:
            click.echo(kinds_markdown(registry), nl=False)
            return
        width = max(map(len, registry.names()), default=0)
        for name in registry.names():
            summary = registry.get(name).summary
            click.echo(f"{name:<{width}}  {summary}  [{registry.origin(name)}]")
    except CyborgError as exc:
        _fail(exc)


@cli.command()
@click.argument("file", type=click.Path(path_type=Path))
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path),
    required=True,
    help="out.svg, out.png, out.pdf or out.dot",
)
def graph(file: Path, output: Path) -> None:
    """Draw the states and transitions of FILE with Graphviz."""
    from cyborg.controller.graph import render

    try:
        render(load_config(file).machine, output)
    except CyborgError as exc:
        _fail(exc)
    click.echo(f"wrote {output}")


def _parse_speed(value: str | None) -> float | str | None:
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


def _check_port(ctx: click.Context, param: click.Parameter, value: int) -> int:
    if not 0 <= value <= 65535:
        raise click.BadParameter(f"{value} is not a TCP port; fix: use 1-65535, or 0 for any free port")
    return value


def _check_duration(ctx: click.Context, param: click.Parameter, value: float | None) -> float | None:
    if value is None:
        return None
    if not (math.isfinite(value) and 0 <= value <= MAX_SCRIPT_SECONDS):
        raise click.BadParameter(
            f"{value!r} is not a duration; fix: give seconds from 0 to {MAX_SCRIPT_SECONDS:.0f} (a year), "
            "or leave --duration out to run until stopped"
        )
    return value


def _check_data_folder(ctx: click.Context, param: click.Parameter, value: Path | None) -> Path | None:
    if value is not None and value.exists() and not value.is_dir():
        raise click.BadParameter(
            f"{value} is a file, not a folder; fix: give a folder for the databases (it is made if missing)"
        )
    return value


duration_option = click.option(
    "--duration",
    type=float,
    default=None,
    callback=_check_duration,
    help="stop after this many (virtual) seconds",
)


def _check_factor(ctx: click.Context, param: click.Parameter, value: float | None) -> float | None:
    if value is not None and not (math.isfinite(value) and value <= MAX_SPEED):
        raise click.BadParameter(
            f"{value!r} is not a usable factor; fix: use e.g. --speed 20 (at most {MAX_SPEED:g})"
        )
    return value


def _os_problem(exc: OSError) -> CyborgError:
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


@cli.command()
@click.option(
    "--config",
    "config_path",
    type=click.Path(path_type=Path),
    help="state machine YAML (default: the packaged Cyborg)",
)
@click.option(
    "--map",
    "map_path",
    type=click.Path(path_type=Path),
    help="map for the simulated base: ARNL .map or map_server .yaml",
)
@click.option("--speed", default=None, help="virtual time: a factor (10) or 'max'; default real time")
@duration_option
@click.option("--host", default="127.0.0.1", show_default=True, help="address the API and dashboard bind to")
@click.option(
    "--port",
    default=8642,
    show_default=True,
    type=int,
    callback=_check_port,
    help="port of the API and dashboard (0: any free port)",
)
@click.option(
    "--db",
    "--data-dir",
    "data_dir",
    type=click.Path(path_type=Path),
    default=None,
    help="folder of the databases (default: $CYBORG_DATA_DIR or ~/.local/share/cyborg; scripts: a temporary one)",
)
@click.option(
    "--script", "script_path", type=click.Path(path_type=Path), help="scenario script to run (YAML)"
)
@click.option(
    "--transcript",
    "transcript_path",
    type=click.Path(path_type=Path),
    help="write the run's records here (JSON lines)",
)
@click.option(
    "--ros",
    "over_ros",
    is_flag=True,
    help="run every part as its own ROS 1 node (as `cyborg launch`); with --script, the script too",
)
@access_options
def sim(
    config_path: Path | None,
    map_path: Path | None,
    speed: str | None,
    duration: float | None,
    host: str,
    port: int,
    data_dir: Path | None,
    script_path: Path | None,
    transcript_path: Path | None,
    over_ros: bool,
    access: Access,
) -> None:
    """Run the whole simulated robot in this process, with its API and dashboard.

    With --script, run a scenario on a fresh robot in virtual time and write its transcript.
    With --ros, the robot runs as ROS nodes, one process per part, in virtual time with --speed.
    """
    try:
        config = _load(config_path)
        check_modules(config)
        for warning in config.warnings:
            click.secho(f"warning: {warning}", fg="yellow", err=True)
        if map_path is not None and not map_path.exists():
            raise CyborgError(
                f"map file {map_path} does not exist; fix: check the path (e.g. ../shared/maps/glassgarden.map)"
            )
        if over_ros:
            _sim_over_ros(config, speed, duration, port, data_dir, script_path, transcript_path, map_path)
            return
        if script_path is not None:
            _run_script(config, script_path, transcript_path, speed, data_dir, map_path)
            return
        if transcript_path is not None:
            raise click.UsageError("--transcript goes with --script")
        import asyncio

        from cyborg.interfaces.serve import serve_api
        from cyborg.sim.runner import run_sim

        asyncio.set_event_loop(None)
        run_sim(
            config,
            speed=_parse_speed(speed),
            duration=duration,
            echo=click.echo,
            serve=serve_api(host, port, click.secho, access),
            data_dir=data_dir,
            map_path=map_path,
        )
    except CyborgError as exc:
        _fail(exc)
    except OSError as exc:
        _fail(_os_problem(exc))
    except KeyboardInterrupt:
        click.echo("stopped")


def _ros_speed(speed: str | None) -> float | None:
    """--speed over ROS: real time (None) or a factor; 'max' has no meaning across processes."""
    parsed = _parse_speed(speed)
    if parsed is None:
        raise click.BadParameter(
            "'max' needs one process; over ROS the nodes share a clock running at a fixed speed: "
            "use e.g. --speed 20",
            param_hint="--speed",
        )
    return None if parsed == "real" else float(parsed)


def _sim_over_ros(
    config: LoadedConfig,
    speed: str | None,
    duration: float | None,
    port: int,
    data_dir: Path | None,
    script_path: Path | None,
    transcript_path: Path | None,
    map_path: Path | None,
) -> None:
    from cyborg.interfaces.ros_launch import all_parts, launch, run_scenario_ros
    from cyborg.sim.runner import default_data_dir

    factor = _ros_speed(speed)
    config_path = Path(config.source).resolve()
    if script_path is None:
        if transcript_path is not None:
            raise click.UsageError("--transcript goes with --script")
        folder = (data_dir or default_data_dir()).resolve()
        launch(
            config_path,
            config,
            all_parts(config),
            folder,
            map_path,
            port,
            echo=True,
            speed=factor,
            duration=duration,
        )
        return
    records = run_scenario_ros(
        config_path,
        config,
        script_path,
        transcript_path=transcript_path.resolve() if transcript_path else None,
        speed=factor or 1.0,
        data_dir=data_dir.resolve() if data_dir else None,
        map_path=map_path.resolve() if map_path else None,
        echo=True,
    )
    _echo_records(records)
    if transcript_path:
        click.secho(f"wrote {len(records)} records to {transcript_path}", fg="green")


def _echo_records(records: list[dict[str, object]]) -> None:
    for record in records:
        _echo_record(record)


def _echo_record(record: dict[str, object]) -> None:
    t = float(record["t"])  # type: ignore[arg-type]
    if record["type"] == "state":
        click.echo(f"[{t:8.1f}s] {record['from'] or '-'} --{record['event']}--> {record['to']}")
    elif record["type"] in ("say", "heard"):
        who = "Cyborg" if record["type"] == "say" else "User"
        click.echo(f"[{t:8.1f}s] {who}: {record['text']}")


def _run_script(
    config: LoadedConfig,
    script_path: Path,
    transcript_path: Path | None,
    speed: str | None,
    data_dir: Path | None,
    map_path: Path | None,
) -> None:
    import contextlib

    from cyborg.sim.scenario import run_scenario
    from cyborg.sim.script import load_script

    script = load_script(script_path)
    parsed = _parse_speed(speed)
    virtual_speed = 1.0 if parsed == "real" else (None if parsed is None else float(parsed))
    count = 0

    def echo(record: dict[str, object]) -> None:
        nonlocal count
        count += 1
        _echo_record(record)

    with contextlib.ExitStack() as stack:
        out = None
        if transcript_path is not None:
            try:
                out = stack.enter_context(transcript_path.open("w", encoding="utf-8"))
            except OSError as exc:
                raise CyborgError(
                    f"cannot write the transcript {transcript_path}: {exc.strerror}; fix: create the folder "
                    f"{transcript_path.parent} first, or give a writable path"
                ) from exc
        # Each record is echoed and written as it happens; none is kept, so memory stays flat.
        run_scenario(
            config,
            script,
            transcript=out,
            data_dir=data_dir,
            speed=virtual_speed,
            map_path=map_path,
            keep_records=False,
            on_record=echo,
        )
    if transcript_path:
        click.secho(f"wrote {count} records to {transcript_path}", fg="green")


_speed_help = "virtual time at this factor of real time (all nodes share one clock); default real time"


@cli.command("node")
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
    callback=_check_data_folder,
    help="folder of the databases",
)
@click.option("--map", "map_path", type=click.Path(path_type=Path), help="map for the simulated base")
@click.option("--host", default="127.0.0.1", show_default=True, help="address of the API (cyborg_api only)")
@click.option(
    "--port",
    default=8642,
    show_default=True,
    type=int,
    callback=_check_port,
    help="port of the API (cyborg_api only)",
)
@click.option("--seed", default=0, show_default=True, type=int, help="seed of the node's randomness")
@click.option("--speed", type=float, default=None, callback=_check_factor, help=_speed_help)
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
    access: Access,
) -> None:
    """Run one part of the robot as the ROS 1 node NAME (cyborg_controller, a module, a gatekeeper,
    cyborg_api, or cyborg_scenario with --script)."""
    from cyborg.interfaces.ros_commands import ScenarioFiles, SimTime, parse_epoch, parse_start, run_node
    from cyborg.sim.runner import default_data_dir

    if speed is not None and speed <= 0:
        raise click.BadParameter(f"{speed!r} must be positive", param_hint="--speed")
    sim_time = SimTime(speed=speed, epoch=parse_epoch(epoch), start=parse_start(start_at))
    scenario = ScenarioFiles(script_path, transcript_path) if script_path is not None else None
    try:
        config = _load(config_path)  # the part checks its own module's settings, loading only its kind
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
        )
    except CyborgError as exc:
        _fail(exc)


@cli.command("launch")
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
    callback=_check_data_folder,
    help="folder of the databases",
)
@click.option("--map", "map_path", type=click.Path(path_type=Path), help="map for the simulated base")
@click.option(
    "--port", default=8642, show_default=True, type=int, callback=_check_port, help="port of the API node"
)
@click.option("--only", multiple=True, help="launch only these parts (repeatable)")
@click.option(
    "--write",
    "write_path",
    type=click.Path(path_type=Path),
    help="write a roslaunch file instead of launching",
)
@click.option(
    "--speed", type=float, default=None, callback=_check_factor, help=_speed_help + "; sets /use_sim_time"
)
@click.option("--start", "start_at", default=None, help="with --speed: virtual start, ISO date-time (UTC)")
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
    duration: float | None,
) -> None:
    """Start the whole robot over ROS 1: a master if none runs, then one process per part.

    With --speed N every node runs in virtual time at N times real time from one shared origin,
    /use_sim_time is set and the simulated base publishes /clock.
    """
    from cyborg.interfaces.ros_commands import parse_start
    from cyborg.interfaces.ros_launch import all_parts, launch, roslaunch_xml
    from cyborg.sim.runner import default_data_dir

    if speed is not None and speed <= 0:
        raise click.BadParameter(f"{speed!r} must be positive", param_hint="--speed")
    start = parse_start(start_at)

    try:
        config = _load(config_path)
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
        )
    except CyborgError as exc:
        _fail(exc)


def _add_tool_commands() -> None:
    from cyborg.interfaces.command_tool import COMMANDS  # light: click and urllib

    for command in COMMANDS:
        cli.add_command(command)  # `db` is lazy: see the group's ``lazy``


_add_tool_commands()


def main() -> None:
    # roslaunch appends remappings such as __name:=x and __log:=y; they are not our options.
    sys.argv = [arg for arg in sys.argv if ":=" not in arg]
    cli()


if __name__ == "__main__":
    main()
