"""``cyborg sim``: the whole simulated robot in this process (or as ROS nodes), or a scenario run."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from cyborg.cli.common import (
    access_options,
    check_modules,
    check_port,
    config_option,
    data_dir_option,
    duration_option,
    fail,
    load_or_default,
    map_option,
    middleware_for,
    os_problem,
    parse_speed,
)
from cyborg.cli.recording import record_options, recorder_settings
from cyborg.errors import CyborgError
from cyborg.web.access import Access

if TYPE_CHECKING:
    from cyborg.app.config import LoadedConfig
    from cyborg.observe.recorder import RecorderSettings
    from cyborg.run.middleware import Middleware


@click.command()
@config_option
@map_option
@click.option("--speed", default=None, help="virtual time: a factor (10) or 'max'; default real time")
@duration_option
@click.option("--host", default="127.0.0.1", show_default=True, help="address the API and dashboard bind to")
@click.option(
    "--port",
    default=8642,
    show_default=True,
    type=int,
    callback=check_port,
    help="port of the API and dashboard (0: any free port)",
)
@data_dir_option(
    "folder of the databases (default: $CYBORG_DATA_DIR or ~/.local/share/cyborg; scripts: a temporary one)",
    checked=False,
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
@click.option(
    "--ros2",
    "over_ros2",
    is_flag=True,
    help="as --ros, on ROS 2 (`cyborg launch --ros2`: rclpy nodes in .venv-ros2, no master)",
)
@click.option(
    "--mic",
    is_flag=True,
    help="the robot hears the machine's microphone (adds a speech_input module; offline, pocketsphinx)",
)
@record_options
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
    over_ros2: bool,
    mic: bool,
    record_path: Path | None,
    no_record: bool,
    access: Access,
) -> None:
    """Run the whole simulated robot in this process, with its API and dashboard.

    With --script, run a scenario on a fresh robot in virtual time and write its transcript.
    With --ros, the robot runs as ROS nodes, one process per part, in virtual time with --speed;
    --ros2 the same on ROS 2.
    """
    try:
        config = load_or_default(config_path)
        if over_ros and over_ros2:
            raise click.UsageError("--ros and --ros2 exclude each other: pick one")
        if mic:
            if over_ros or over_ros2 or script_path is not None:
                raise click.UsageError(
                    "--mic goes with the interactive sim, not with --ros, --ros2 or --script"
                )
            config.model.modules.setdefault(MIC_MODULE, {"kind": "speech_input", "source": "microphone"})
        check_modules(config)
        for warning in config.warnings:
            click.secho(f"warning: {warning}", fg="yellow", err=True)
        if map_path is not None and not map_path.exists():
            raise CyborgError(
                f"map file {map_path} does not exist; fix: check the path (e.g. ../shared/maps/glassgarden.map)"
            )
        if over_ros or over_ros2:
            _sim_over_ros(
                config,
                speed,
                duration,
                port,
                data_dir,
                script_path,
                transcript_path,
                map_path,
                middleware=middleware_for(over_ros2),
                record_path=record_path,
                no_record=no_record,
            )
            return
        record = recorder_settings(config, record_path, no_record, data_dir)
        if script_path is not None:
            _run_script(config, script_path, transcript_path, speed, data_dir, map_path, record)
            return
        if transcript_path is not None:
            raise click.UsageError("--transcript goes with --script")
        import asyncio

        from cyborg.run.local import run_sim
        from cyborg.web.build import serve_api

        asyncio.set_event_loop(None)
        run_sim(
            config,
            speed=parse_speed(speed),
            duration=duration,
            echo=click.echo,
            serve=serve_api(host, port, click.secho, access),
            data_dir=data_dir,
            map_path=map_path,
            record=record,
        )
    except CyborgError as exc:
        fail(exc)
    except OSError as exc:
        fail(os_problem(exc))
    except KeyboardInterrupt:
        click.echo("stopped")


MIC_MODULE = "cyborg_speech_input"
"""The module ``cyborg sim --mic`` adds (unless the configuration has one of that name)."""


def _ros_speed(speed: str | None) -> tuple[float | None, bool]:
    """--speed over ROS: real time (None), a factor, or 'max' (lockstep: the second value)."""
    parsed = parse_speed(speed)
    if parsed is None:
        return None, True
    return (None if parsed == "real" else float(parsed)), False


def _sim_over_ros(
    config: LoadedConfig,
    speed: str | None,
    duration: float | None,
    port: int,
    data_dir: Path | None,
    script_path: Path | None,
    transcript_path: Path | None,
    map_path: Path | None,
    *,
    middleware: Middleware,
    record_path: Path | None = None,
    no_record: bool = False,
) -> None:
    from cyborg.app.parts import RECORDER
    from cyborg.run.datadir import default_data_dir
    from cyborg.run.roslaunch import all_parts, with_recorder
    from cyborg.run.scenario import run_scenario_ros
    from cyborg.run.supervisor import Launch, launch

    if no_record and record_path is not None:
        raise click.UsageError("--record and --no-record exclude each other: pick one")
    factor, lockstep = _ros_speed(speed)
    config_path = Path(config.source).resolve()
    if script_path is None:
        if transcript_path is not None:
            raise click.UsageError("--transcript goes with --script")
        folder = (data_dir or default_data_dir()).resolve()
        parts = all_parts(config)
        parts, extra = with_recorder(parts, record_path, no_record, default=RECORDER in parts)
        robot = Launch(
            config_path,
            config,
            parts,
            folder,
            map_path,
            port,
            speed=factor,
            lockstep=lockstep,
            middleware=middleware,
            extra_args=extra,
        )
        launch(robot, duration=duration)
        return
    records = run_scenario_ros(
        config_path,
        config,
        script_path,
        transcript_path=transcript_path.resolve() if transcript_path else None,
        speed=None if lockstep else factor or 1.0,
        data_dir=data_dir.resolve() if data_dir else None,
        map_path=map_path.resolve() if map_path else None,
        echo=True,
        middleware=middleware,
        record=None if no_record else record_path,
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
    record: RecorderSettings | None = None,
) -> None:
    import contextlib

    from cyborg.sim.scenario import run_scenario
    from cyborg.sim.script import load_script

    script = load_script(script_path)
    parsed = parse_speed(speed)
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
        try:
            result = run_scenario(
                config,
                script,
                transcript=out,
                data_dir=data_dir,
                speed=virtual_speed,
                map_path=map_path,
                keep_records=False,
                on_record=echo,
                stop_on_interrupt=True,
                record=record,
            )
        except KeyboardInterrupt:
            written = f"; wrote {count} records to {transcript_path}" if transcript_path else ""
            click.echo(f"stopped (Ctrl-C){written}")
            return
    if transcript_path:
        click.secho(f"wrote {count} records to {transcript_path}", fg="green")
    for recording in result.recordings:
        click.echo(f"recorded to {recording}")
    click.secho(result.summary, fg="green")
