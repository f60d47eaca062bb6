"""``cyborg validate``, ``cyborg kinds`` and ``cyborg graph``: a state machine file and the module kinds."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from cyborg.cli.common import check_modules, fail, load_config
from cyborg.errors import CyborgError

__all__ = ["graph", "kinds", "validate"]


@click.command()
@click.argument("file", type=click.Path(path_type=Path))
@click.option("--strict", is_flag=True, help="warnings count as problems: exit 1 when there is one")
def validate(file: Path, strict: bool) -> None:
    """Check a state machine YAML FILE; exit 0 if valid, 1 with the problems otherwise.

    With a modules: section it also warns about the robot as a whole: states no module serves,
    resources granted to no module's node, events no state takes, speech without a grant, and
    modules listening for the same phrase. Warnings leave the exit code 0 unless --strict."""
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
    if strict and warnings:
        click.secho(
            f"{file}: {len(warnings)} warning(s) with --strict; fix: what each says, or drop --strict",
            fg="red",
            err=True,
        )
        sys.exit(1)
    note = f", {len(warnings)} warning(s) above" if warnings else ""
    click.echo(f"{file}: valid ({leaves} states, initial {loaded.machine.initial!r}{note})")
    if any(state.parallel for state in loaded.machine.states.values()):
        from cyborg.controller.clashes import explore

        found = explore(loaded.machine)
        click.echo(
            f"parallel state(s): {found.parallel_configurations} combinations of their regions' states "
            "reachable, no exclusive clash"
        )


@click.command()
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


@click.command()
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
    from cyborg.drawing.graph import render

    try:
        render(load_config(file).machine, output)
    except CyborgError as exc:
        fail(exc)
    click.echo(f"wrote {output}")
