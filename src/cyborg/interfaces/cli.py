"""The ``cyborg`` command line: validate and draw machines, run the simulated robot, tools.

Top of the import chain: it may use every layer below it.
"""

from __future__ import annotations

import asyncio
import logging
import sys
from importlib import resources
from pathlib import Path

import click

from cyborg.controller.config import LoadedConfig, load_config
from cyborg.errors import CyborgError

DEFAULT_CONFIG = "cyborg.yaml"


def packaged_config(name: str) -> Path:
    """Path of a configuration file shipped with the package (``src/cyborg/data``)."""
    return Path(str(resources.files("cyborg") / "data" / name))


def _load(path: Path | None) -> LoadedConfig:
    if path is None:
        path = packaged_config(DEFAULT_CONFIG)
        if not path.exists():
            path = packaged_config("demo.yaml")
    return load_config(path)


def check_modules(loaded: LoadedConfig) -> None:
    """Validate the ``modules:`` section against the known module kinds."""
    from cyborg.sim.kinds import MODULE_KINDS, parse_module_settings

    for name, raw in loaded.model.modules.items():
        parse_module_settings(name, raw, MODULE_KINDS, loaded.source)


def _fail(exc: CyborgError) -> None:
    click.secho(str(exc), fg="red", err=True)
    sys.exit(1)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
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
    if speed <= 0:
        raise click.BadParameter(f"{value!r} must be positive")
    return speed


@cli.command()
@click.option(
    "--config",
    "config_path",
    type=click.Path(path_type=Path),
    help="state machine YAML (default: the packaged Cyborg)",
)
@click.option("--speed", default=None, help="virtual time: a factor (10) or 'max'; default real time")
@click.option("--duration", type=float, default=None, help="stop after this many (virtual) seconds")
@click.option("--host", default="127.0.0.1", show_default=True, help="address the API and dashboard bind to")
@click.option(
    "--port",
    default=8642,
    show_default=True,
    type=int,
    help="port of the API and dashboard (0: any free port)",
)
@click.option(
    "--data-dir",
    type=click.Path(path_type=Path),
    default=None,
    help="databases (default: $CYBORG_DATA_DIR or ~/.local/share/cyborg)",
)
def sim(
    config_path: Path | None,
    speed: str | None,
    duration: float | None,
    host: str,
    port: int,
    data_dir: Path | None,
) -> None:
    """Run the whole simulated robot in this process, with its API and dashboard."""
    from cyborg.interfaces.api import RobotAPI
    from cyborg.sim.runner import run_sim

    async def serve(transport, robot):  # type: ignore[no-untyped-def]
        api = RobotAPI(transport.node("cyborg_api"), machine=robot.config.machine)
        try:
            url = await api.start(host, port)
        except OSError as exc:
            raise CyborgError(
                f"cannot serve on {host}:{port}: {exc.strerror}; fix: pass --port 0 or another port"
            ) from exc
        click.secho(f"dashboard and API: {url}  (try: cyborg status --url {url.rstrip('/')})", fg="green")
        return api.stop

    try:
        config = _load(config_path)
        for warning in config.warnings:
            click.secho(f"warning: {warning}", fg="yellow", err=True)
        asyncio.set_event_loop(None)
        run_sim(
            config,
            speed=_parse_speed(speed),
            duration=duration,
            echo=click.echo,
            serve=serve,
            data_dir=data_dir,
        )
    except CyborgError as exc:
        _fail(exc)
    except KeyboardInterrupt:
        click.echo("stopped")


def _add_tool_commands() -> None:
    from cyborg.interfaces.command_tool import COMMANDS

    for command in COMMANDS:
        cli.add_command(command)


_add_tool_commands()


def main() -> None:
    cli()


if __name__ == "__main__":
    main()
