"""The ``cyborg`` command line: validate and draw machines, run the simulated robot, tools.

Top of the import chain: it may use every layer below it, but imports each part only in the
command that needs it, so that ``cyborg --help`` and the command tool (``cyborg say``) load
click and an HTTP client only, and ``cyborg node`` only its own part.
"""

from __future__ import annotations

import importlib
import logging
import sys
from pathlib import Path

import click

from cyborg.errors import CyborgError
from cyborg.interfaces.cli_common import check_modules, fail, load_config, packaged_config

__all__ = ["cli", "main", "packaged_config"]


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
        ),
        "listen": (
            "cyborg.interfaces.cli_listen:listen",
            "Hear speech (offline) and print each sentence with its confidence; rejected ones are marked.",
        ),
        "new": (
            "cyborg.interfaces.cli_new:new_group",
            "Start something new from a template: a behaviour module.",
        ),
        "sim": (
            "cyborg.interfaces.cli_sim:sim",
            "Run the whole simulated robot in this process, with its API and dashboard.",
        ),
        "node": (
            "cyborg.interfaces.cli_ros:node",
            "Run one part of the robot as the ROS 1 node NAME (cyborg_controller, a module, a "
            "gatekeeper, cyborg_api, or cyborg_scenario with --script); with --ros2 as a ROS 2 node.",
        ),
        "launch": (
            "cyborg.interfaces.cli_ros:launch_command",
            "Start the whole robot over ROS 1 (a master if none runs) or ROS 2 (--ros2), a process a part.",
        ),
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
    """Check a state machine YAML FILE; exit 0 if valid, 1 with the problems otherwise.

    With a modules: section it also warns about the robot as a whole: states no module serves,
    resources granted to no module's node, and modules listening for the same phrase."""
    from cyborg.app.checks import robot_warnings
    from cyborg.app.registry import module_kinds

    try:
        loaded = load_config(file)
        check_modules(loaded)
        warnings = [*loaded.warnings, *robot_warnings(loaded, module_kinds())]
    except CyborgError as exc:
        fail(exc)
        return
    for warning in warnings:
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
        fail(exc)


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
        fail(exc)
    click.echo(f"wrote {output}")


def _add_tool_commands() -> None:
    from cyborg.interfaces.command_tool import COMMANDS  # light: click and urllib

    for command in COMMANDS:
        cli.add_command(command)  # `db`, `sim`, `node` and `launch` are lazy: see the group's ``lazy``


_add_tool_commands()


def main() -> None:
    # roslaunch appends remappings such as __name:=x and __log:=y; they are not our options.
    sys.argv = [arg for arg in sys.argv if ":=" not in arg]
    cli()


if __name__ == "__main__":
    main()
