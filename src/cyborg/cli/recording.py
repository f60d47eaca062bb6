"""What the commands that run a robot share about its recording: ``--record``/``--no-record``
and where the recordings go (the configuration's ``recording`` section)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

if TYPE_CHECKING:
    from cyborg.app.config import LoadedConfig
    from cyborg.observe.recorder import RecorderSettings

RECORDINGS_ENV = "CYBORG_RECORDINGS_DIR"
"""Where recordings go when the configuration names no folder (before the data folder's recordings/)."""


def record_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """``--record FILE.mcap`` and ``--no-record`` (``record_path``, ``no_record``)."""
    command = click.option(
        "--no-record", is_flag=True, help="record nothing (every run is recorded to MCAP otherwise)"
    )(command)
    return click.option(
        "--record",
        "record_path",
        type=click.Path(path_type=Path, dir_okay=False),
        default=None,
        help="record the run to this MCAP file (default: a new file in the data folder's recordings/)",
    )(command)


def recorder_settings(
    config: LoadedConfig,
    record_path: Path | None,
    no_record: bool,
    data_dir: Path | None,
    *,
    enabled: bool | None = None,
) -> RecorderSettings | None:
    """Where this run is recorded, or None (``--no-record``, or ``recording: {enabled: false}``
    unless ``enabled`` overrides it)."""
    from cyborg.observe.recorder import RecorderSettings

    if no_record and record_path is not None:
        raise click.UsageError("--record and --no-record exclude each other: pick one")
    settings = config.model.recording
    if no_record or (record_path is None and not (settings.enabled if enabled is None else enabled)):
        return None
    common: dict[str, Any] = {
        "budget_bytes": int(settings.budget_mb * 1024**2),
        "segment_seconds": settings.segment_minutes * 60.0,
        "segment_bytes": int(settings.segment_mb * 1024**2),
    }
    if record_path is not None:
        return RecorderSettings(file=record_path, **common)
    return RecorderSettings(folder=recordings_folder(config, data_dir), **common)


def recordings_folder(config: LoadedConfig, data_dir: Path | None) -> Path:
    """The configuration's folder, else $CYBORG_RECORDINGS_DIR, else the data folder's recordings/."""
    from cyborg.run.datadir import default_data_dir

    named = config.model.recording.folder
    if named:
        return Path(named).expanduser()
    env = os.environ.get(RECORDINGS_ENV)
    if env:
        return Path(env)
    return (data_dir or default_data_dir()) / "recordings"
