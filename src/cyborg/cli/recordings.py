"""``cyborg rerun``, ``cyborg replay`` and ``cyborg export``: what is done with a recording."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from cyborg.cli.common import fail, os_problem
from cyborg.errors import CyborgError


def _open(path: Path):  # type: ignore[no-untyped-def]
    from cyborg.observe.recording import open_recording

    recording = open_recording(path)
    if recording.problem:
        click.secho(f"warning: {recording.problem}", fg="yellow", err=True)
    return recording


@click.command()
@click.argument("file", type=click.Path(path_type=Path))
@click.option(
    "--transcript",
    "transcript_path",
    type=click.Path(path_type=Path, dir_okay=False),
    help="write the re-run's transcript here (JSON lines)",
)
@click.option(
    "--config",
    "config_path",
    type=click.Path(path_type=Path, dir_okay=False),
    help="re-run with this configuration instead of the recorded one, and say where the decisions first differ",
)
def rerun(file: Path, transcript_path: Path | None, config_path: Path | None) -> None:
    """Re-run the recording FILE from its recorded inputs and compare what the robot did.

    A fresh robot (the recorded configuration, seed, start and calendar) hears and is sent what
    the recording says came from outside, at the same nanosecond. A recording made in real time
    (a launch over ROS 1 or ROS 2) re-runs the controller alone against the events and module
    outcomes it recorded. Exit 0 when the decisions are the same as recorded, 1 when they differ
    (with where they first differ).
    """
    try:
        from cyborg.sim.rerun import first_difference, write_transcript
        from cyborg.sim.rerun import rerun as run_again

        recording = _open(file)
        config = None
        if config_path is not None:
            from cyborg.app.config import load_config

            config = load_config(config_path)
        if recording.metadata.get("clock", "").startswith("real"):
            _rerun_controller(recording, config, config_path, transcript_path)
            return
        result = run_again(recording, config=config)
        for line in result.skipped:
            click.secho(f"warning: {line}", fg="yellow", err=True)
        if transcript_path is not None:
            write_transcript(transcript_path, result.transcript)
            click.echo(f"wrote {len(result.records)} records to {transcript_path}")
        difference = first_difference(recording.records, result.records)
        what = f"with {config_path}" if config_path is not None else "the re-run"
        if difference is None:
            same = result.records == recording.records
            click.secho(
                f"same decisions as recorded ({len(recording.records)} records"
                f"{', every record the same' if same else ''})",
                fg="green",
            )
            return
        click.echo(f"the decisions first differ at {difference.describe(what)}")
        raise SystemExit(1)
    except CyborgError as exc:
        fail(exc)
    except OSError as exc:
        fail(os_problem(exc))


def _rerun_controller(
    recording: Any, config: Any, config_path: Path | None, transcript_path: Path | None
) -> None:
    """``cyborg rerun`` of a real-time recording: the controller alone (cyborg.sim.rerun_controller)."""
    from cyborg.sim.rerun import recorded_config, transcript_of, write_transcript
    from cyborg.sim.rerun_controller import first_state_difference, rerun_controller

    machine = (config or recorded_config(recording)).machine
    result = rerun_controller(recording, machine)
    over = recording.metadata.get("middleware") or "a graph"
    click.echo(
        f"{recording.path} was recorded over {over} in real time: the controller alone re-ran against "
        f"its {result.events} recorded events and {result.outcomes} module outcomes (in virtual time)"
    )
    if transcript_path is not None:
        write_transcript(transcript_path, transcript_of(result.changes))
        click.echo(f"wrote {len(result.changes)} state changes to {transcript_path}")
    recorded = [r for r in recording.records if r["type"] == "state"]
    difference = first_state_difference(recorded, result.changes)
    what = f"with {config_path}" if config_path is not None else "the re-run"
    if difference is None:
        click.secho(f"same state changes as recorded ({len(recorded)})", fg="green")
        return
    click.echo(f"the state changes first differ at {difference.describe(what, noun='state change')}")
    raise SystemExit(1)


@click.command()
@click.argument("file", type=click.Path(path_type=Path))
@click.option(
    "--to",
    "kind",
    type=click.Choice(["rosbag", "rosbag2"]),
    required=True,
    help="rosbag: a ROS 1 .bag; rosbag2: a ROS 2 bag folder (MCAP storage)",
)
@click.option(
    "-o", "--output", "out", type=click.Path(path_type=Path), required=True, help="the bag to write"
)
def export(file: Path, kind: str, out: Path) -> None:
    """Export the recording FILE as a ROS 1 or ROS 2 bag of the thesis's messages."""
    try:
        from cyborg.observe.export import BagKind
        from cyborg.observe.export import export as write_bag

        count = write_bag(_open(file), BagKind(kind), out)
        click.secho(f"wrote {count} messages to {out}", fg="green")
    except CyborgError as exc:
        fail(exc)
    except OSError as exc:
        fail(os_problem(exc))


@click.command()
@click.argument("file", type=click.Path(path_type=Path))
@click.option("--host", default="127.0.0.1", show_default=True, help="address to serve on")
@click.option("--port", default=8643, show_default=True, type=int, help="port (0: any free port)")
def replay(file: Path, host: str, port: int) -> None:
    """Serve the dashboard on the recording FILE: a time slider, play/pause and speed."""
    try:
        from cyborg.web.replay import ReplayAPI, serve_replay

        api = ReplayAPI.of_file(file)
        if api.recording is not None and api.recording.problem:
            click.secho(f"warning: {api.recording.problem}", fg="yellow", err=True)
        serve_replay(api, host, port, lambda url: click.secho(f"replay of {file} at {url}", fg="green"))
    except CyborgError as exc:
        fail(exc)
    except OSError as exc:
        fail(os_problem(exc))
    except KeyboardInterrupt:
        click.echo("stopped")
