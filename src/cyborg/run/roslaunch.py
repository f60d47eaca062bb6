"""A roslaunch file that starts the robot's nodes (``cyborg launch --write``), and the parts to start."""

from __future__ import annotations

import xml.sax.saxutils
from pathlib import Path

from cyborg.app.config import LoadedConfig
from cyborg.app.parts import CONTROLLER, RECORDER, part_names

__all__ = ["all_parts", "roslaunch_xml", "with_recorder"]


def roslaunch_xml(config_path: Path, parts: list[str], data_dir: Path) -> str:
    """A roslaunch file starting the same nodes (for people who prefer roslaunch)."""
    lines = [
        "<launch>",
        "  <!-- written by cyborg launch (write option): one node per part; the roslaunch node name is",
        "       the part's, since roslaunch renames the node it starts and gatekeepers go by names -->",
    ]
    for name in parts:
        fresh = " --fresh" if name == CONTROLLER else ""
        args = xml.sax.saxutils.quoteattr(f"node {name} --config {config_path} --db {data_dir}{fresh}")
        lines.append(
            f'  <node name="{name}" pkg="cyborg_controller" type="cyborg" args={args} required="true" output="screen"/>'
        )
    lines.append("</launch>")
    return "\n".join(lines) + "\n"


def all_parts(config: LoadedConfig) -> list[str]:
    return part_names(config)


def with_recorder(
    parts: list[str], record_path: Path | None, no_record: bool, *, default: bool = True
) -> tuple[list[str], dict[str, list[str]]]:
    """The parts of a launch with the recorder node as asked (``--record FILE``: it records there;
    ``--no-record``: none; else as ``default`` says), and the recorder's extra arguments."""
    parts = [part for part in parts if part != RECORDER]
    if no_record or (record_path is None and not default):
        return parts, {}
    parts.insert(1 if parts and parts[0] == CONTROLLER else 0, RECORDER)
    return parts, ({RECORDER: ["--record", str(record_path.resolve())]} if record_path is not None else {})
