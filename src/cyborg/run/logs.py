"""Where a node's log lines go: its log file, and its warnings and errors on the terminal.

Under ``cyborg launch`` every node's stderr is the launch's terminal, so each node sends its
problems there, prefixed ``[name]``, and everything else to its log file (rospy's on ROS 1, the
same folder's on ROS 2: :meth:`cyborg.run.middleware.Middleware.log_file`).
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

__all__ = ["log_to_file", "show_problems_on_stderr"]


def log_to_file(path: Path, name: str) -> None:
    """Every log line of node ``name`` to ``path`` (as rospy does on ROS 1), warnings and errors
    also to stderr (:func:`show_problems_on_stderr`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    root = logging.getLogger()
    for handler in list(root.handlers):
        if isinstance(handler, logging.StreamHandler) and getattr(handler, "stream", None) is sys.stderr:
            root.removeHandler(handler)
    to_file = logging.FileHandler(path, encoding="utf-8")
    to_file.setFormatter(logging.Formatter("%(asctime)s %(levelname)-7s %(name)s: %(message)s"))
    root.addHandler(to_file)
    show_problems_on_stderr(name)


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
