"""The ``cyborg`` command line: one file per command group, each imported when it runs.

``machine`` (validate, kinds, graph), ``sim``, ``ros`` (node, launch), ``tool`` (event, say,
emotion, status), ``listen``, ``new`` and ``db``. Top of the import chain: it may use every layer
below it, but a command imports only what it needs, so that ``cyborg --help`` loads click
alone, the command tool (``cyborg say``) click and urllib, and ``cyborg node`` only its own part.
:mod:`~cyborg.cli.common` holds what the commands share (loading a configuration, failing with a
readable message, checking options); :mod:`~cyborg.cli.recording` the ``--record`` options and
where recordings go; :mod:`~cyborg.cli.recordings` ``rerun``, ``replay`` and ``export``;
:mod:`~cyborg.cli.doctor` ``doctor`` and :mod:`~cyborg.cli.service` ``service`` (the real robot).
"""

from __future__ import annotations

import importlib
import logging
import sys

import click

__all__ = ["cli", "main"]


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
        "validate": (
            "cyborg.cli.machine:validate",
            "Check a state machine YAML FILE; exit 0 if valid, 1 with the problems otherwise.",
        ),
        "kinds": (
            "cyborg.cli.machine:kinds",
            "List the module kinds this installation knows (built in or from installed packages).",
        ),
        "graph": ("cyborg.cli.machine:graph", "Draw the states and transitions of FILE with Graphviz."),
        "event": ("cyborg.cli.tool:event_command", "Send event NAME to the controller."),
        "say": ("cyborg.cli.tool:say_command", "Send TEXT as if speech-to-text heard it."),
        "emotion": (
            "cyborg.cli.tool:emotion_group",
            "Set the robot's emotion, its PAD values, or switch the emotion system on/off.",
        ),
        "status": (
            "cyborg.cli.tool:status_command",
            "Show the previous state, event, current state, emotion and PAD values.",
        ),
        "db": (
            "cyborg.cli.db:db_group",
            "Locations, calendar events and responses of the navigation module.",
        ),
        "listen": (
            "cyborg.cli.listen:listen",
            "Hear speech (offline) and print each sentence, its confidence and what the robot would do.",
        ),
        "new": (
            "cyborg.cli.new:new_group",
            "Start something new from a template: a behaviour module.",
        ),
        "sim": (
            "cyborg.cli.sim:sim",
            "Run the whole simulated robot in this process, with its API and dashboard.",
        ),
        "node": (
            "cyborg.cli.ros:node",
            "Run one part of the robot as the ROS 1 node NAME (cyborg_controller, a module, a "
            "gatekeeper, cyborg_recorder, cyborg_api, or cyborg_scenario with --script); with --ros2 as a ROS 2 node.",
        ),
        "rerun": (
            "cyborg.cli.recordings:rerun",
            "Re-run the recording FILE from its recorded inputs and compare what the robot did.",
        ),
        "export": (
            "cyborg.cli.recordings:export",
            "Export the recording FILE as a ROS 1 or ROS 2 bag of the thesis's messages.",
        ),
        "replay": (
            "cyborg.cli.recordings:replay",
            "Serve the dashboard on the recording FILE: a time slider, play/pause and speed.",
        ),
        "doctor": (
            "cyborg.cli.doctor:doctor",
            "Check this machine (and with --ros/--ros2 the running graph) against the configuration.",
        ),
        "service": (
            "cyborg.cli.service:service_group",
            "Start the robot when the computer boots: install, status or uninstall a systemd unit.",
        ),
        "launch": (
            "cyborg.cli.ros:launch_command",
            "Start the whole robot over ROS 1 (a master if none runs) or ROS 2 (--ros2), a node a part (see --processes).",
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


def main() -> None:
    # roslaunch appends remappings such as __name:=x and __log:=y; they are not our options.
    sys.argv = [arg for arg in sys.argv if ":=" not in arg]
    cli()


if __name__ == "__main__":
    main()
