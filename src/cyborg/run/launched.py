"""The process of a thin part started by ``cyborg launch``: ``python -m cyborg.run.launched node NAME ...``.

``cyborg launch`` validated the whole configuration before it started any node, and tells each
node so (``--checked DIGEST``). A module of a built-in thin kind
(:data:`cyborg.run.supervisor.THIN_KINDS`) or a
gatekeeper then needs neither the command line's parser (click) nor the validating models
(pydantic): this entry reads the launch's own arguments (:func:`parse_launched`, the form
:meth:`cyborg.run.supervisor.Launch.command` writes), a sketch of the file
(:mod:`cyborg.app.sketch`) and builds the part from it (its kind's dataclass settings made without
pydantic, :func:`cyborg.modules.kind.checked_settings`). Its memory stays near a bare rospy or
rclpy node's (issue 33).

Whatever it cannot run so (the file changed since the launch validated it, a part that is not a
module or gatekeeper of the file, an argument it does not know) it hands to ``cyborg node`` with
the same arguments (``exec``: the same process), which validates the file whole and words any
problem as by hand.
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

if TYPE_CHECKING:
    from cyborg.run.node import NodeOptions

__all__ = ["LaunchedNode", "main", "parse_launched"]

_VALUES = frozenset(
    {
        "--config",
        "--db",
        "--seed",
        "--checked",
        "--map",
        "--port",
        "--with",
        "--lockstep",
        "--start",
        "--speed",
        "--epoch",
    }
)
_FLAGS = frozenset({"--fresh", "--ros2", "--publish-clock", "--no-publish-clock"})
LOG_FORMAT = "%(asctime)s %(levelname)-7s %(name)s: %(message)s"  # as the command line's (cyborg.cli)


@dataclass
class LaunchedNode:
    """What the launch's arguments say of one node's process."""

    name: str
    values: dict[str, str] = field(default_factory=dict)
    also: list[str] = field(default_factory=list)
    flags: set[str] = field(default_factory=set)


def parse_launched(argv: Sequence[str]) -> LaunchedNode | None:
    """The launch's ``node NAME --option value ... --flag`` (None: a form this entry does not take)."""
    if len(argv) < 2 or argv[0] != "node" or argv[1].startswith("-"):
        return None
    node = LaunchedNode(argv[1])
    words = list(argv[2:])
    while words:
        word = words.pop(0)
        if word in _FLAGS:
            node.flags.add(word)
        elif word in _VALUES and words:
            value = words.pop(0)
            if word == "--with":
                node.also.append(value)
            else:
                node.values[word] = value
        else:
            return None
    return node


def main(argv: Sequence[str] | None = None) -> None:
    """Run the node ``argv`` (what follows ``cyborg``) describes; ``cyborg node`` when it cannot."""
    args = list(sys.argv[1:] if argv is None else argv)
    launched = parse_launched(args)
    if launched is None:
        _as_cyborg_node(args)
    from cyborg.errors import CyborgError
    from cyborg.run.census import NAME_TAKEN_EXIT, NameTaken
    from cyborg.run.middleware import ROS1, ROS2
    from cyborg.run.node import run_node

    logging.basicConfig(level=logging.INFO, format=LOG_FORMAT, datefmt="%H:%M:%S")
    middleware = ROS2 if "--ros2" in launched.flags else ROS1
    try:
        options = _options(launched)
        if options is None:
            _as_cyborg_node(args)
        middleware.enter()
        code = run_node(launched.name, options, middleware)
    except NameTaken as exc:
        print(f"node {launched.name} refused to start: {exc}", file=sys.stderr, flush=True)
        sys.exit(NAME_TAKEN_EXIT)  # the launch stops the robot instead of starting the node again
    except CyborgError as exc:
        print(exc, file=sys.stderr, flush=True)
        sys.exit(1)
    sys.exit(code)


def _options(launched: LaunchedNode) -> NodeOptions | None:
    """The node's options from a sketch of its file; None when the file changed since the launch
    validated it, or a part is no module or gatekeeper of it."""
    from cyborg.app.registry import BUILT_IN_KINDS, built_in_kinds
    from cyborg.app.sketch import read_sketch
    from cyborg.run.datadir import default_data_dir
    from cyborg.run.node import NodeOptions
    from cyborg.run.simtime import SimTime
    from cyborg.transport.clock import DEFAULT_VIRTUAL_START

    values = launched.values
    if "--config" not in values or "--checked" not in values:
        return None
    sketch = read_sketch(Path(values["--config"]), values["--checked"])
    if sketch is None or not all(sketch.has_part(name) for name in [launched.name, *launched.also]):
        return None
    modules = sketch.model.modules
    kinds = {str(modules[name].get("kind")) for name in [launched.name, *launched.also] if name in modules}
    start = values.get("--start")
    moment = datetime.fromisoformat(start) if start is not None else DEFAULT_VIRTUAL_START
    epoch = values.get("--epoch")
    publish = {"--publish-clock": True, "--no-publish-clock": False}
    return NodeOptions(
        config=sketch,
        data_dir=Path(values["--db"]) if "--db" in values else default_data_dir(),
        map_path=Path(values["--map"]) if "--map" in values else None,
        seed=int(values.get("--seed", "0")),
        resume="--fresh" not in launched.flags,
        time=SimTime(
            speed=float(values["--speed"]) if "--speed" in values else None,
            epoch=_epoch(epoch),
            start=moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC),
            lockstep=values.get("--lockstep"),
        ),
        publish_clock=next((publish[flag] for flag in launched.flags if flag in publish), None),
        also=tuple(launched.also),
        kinds=built_in_kinds(kinds) if kinds <= BUILT_IN_KINDS.keys() else None,  # no entry points read
    )


def _epoch(value: str | None) -> float | str | None:
    """``--epoch`` as the launch writes it: Unix seconds, or where the nodes meet (param:/dir:)."""
    if value is None:
        return None
    try:
        return float(value)
    except ValueError:
        return value


def _as_cyborg_node(args: list[str]) -> NoReturn:
    """Become ``cyborg ARGS`` (the same process): it validates the file whole, as by hand."""
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(sys.executable, [sys.executable, "-m", "cyborg.cli", *args])


if __name__ == "__main__":
    main()
