"""Where a node's log lines go: its log file, and its warnings and errors on the terminal.

Under ``cyborg launch`` every node's stderr is the launch's terminal, so each node sends its
problems there, prefixed ``[name]``, and everything else to its log file (rospy's on ROS 1, the
same folder's on ROS 2: :meth:`cyborg.run.middleware.Middleware.log_file`). A ROS 2 process that
hosts several nodes writes one file, its first node's; each other node's ``NODE.log`` is a link to
it (:func:`log_to_file`'s ``hosted``), so every node's lines are where ``cyborg launch`` says.
"""

from __future__ import annotations

import logging
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

__all__ = ["log_to_file", "show_problems_on_stderr"]

LINE_FORMAT = "%(asctime)s %(levelname)-7s %(name)s: %(message)s"


def log_to_file(path: Path, name: str, *, hosted: Sequence[Path] = ()) -> None:
    """Every log line of node ``name`` to ``path`` (as rospy does on ROS 1), warnings and errors
    also to stderr (:func:`show_problems_on_stderr`).

    ``hosted``: the log files of the other nodes this process hosts (ROS 2's shared processes).
    Their lines go to ``path`` too (Python's logging does not know which node a line is about);
    each of these files becomes a link to ``path``, or, where a file of that name holds an
    earlier run's lines (the node had a process of its own), gets a line saying where its lines
    are now."""
    path.parent.mkdir(parents=True, exist_ok=True)
    root = logging.getLogger()
    for handler in list(root.handlers):
        if isinstance(handler, logging.StreamHandler) and getattr(handler, "stream", None) is sys.stderr:
            root.removeHandler(handler)
    to_file = logging.FileHandler(path, encoding="utf-8")
    to_file.setFormatter(logging.Formatter(LINE_FORMAT))
    root.addHandler(to_file)
    for other in hosted:
        _point_to(other, path, name)
    show_problems_on_stderr(name)


def _point_to(link: Path, target: Path, host: str) -> None:
    """Make ``link`` lead to the log file ``target`` of the process (node ``host``) that hosts its node."""
    try:
        if link.is_symlink() or not link.exists():
            temporary = link.with_name(f".{link.name}.{os.getpid()}")
            temporary.unlink(missing_ok=True)
            temporary.symlink_to(target.name if target.parent == link.parent else target)
            os.replace(temporary, link)  # at once: a reader never finds it missing
            return
        with link.open("a", encoding="utf-8") as earlier:
            stamp = time.strftime("%Y-%m-%d %H:%M:%S")
            earlier.write(
                f"{stamp} INFO    cyborg.run.logs: from now on this node runs in {host}'s process; "
                f"its lines are in {target}\n"
            )
    except OSError as exc:
        logging.getLogger(__name__).warning(
            "could not point %s to %s, where this node's lines go (%s)", link, target, exc
        )


class _OneWrite(logging.Formatter):
    """A record (traceback included) as one string ending in a newline, written in one go."""

    def format(self, record: logging.LogRecord) -> str:
        return super().format(record).rstrip("\n") + "\n"


def show_problems_on_stderr(name: str) -> None:
    """Warnings and errors of this node also go to stderr, prefixed ``[name]``.

    rospy sends the log to the node's file only; under ``cyborg launch``
    every node's stderr is the launch's terminal, so problems show where the person looks.
    """
    root = logging.getLogger()
    if any(
        isinstance(h, logging.StreamHandler) and getattr(h, "stream", None) is sys.stderr
        for h in root.handlers
    ):
        return  # rospy left the command line's own handler in place: it shows them already
    handler = logging.StreamHandler(sys.stderr)
    handler.terminator = ""  # one write per line: the nodes share the terminal
    handler.setLevel(logging.WARNING)
    handler.setFormatter(_OneWrite(f"[{name}] %(levelname)s %(name)s: %(message)s"))
    logging.getLogger("cyborg").addHandler(handler)
