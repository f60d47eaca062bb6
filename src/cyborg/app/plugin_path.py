"""Where module packages are found: this Python's import path and, from the ROS 2 venv, the main venv's.

A student pip-installs a module package once, into the main venv (``.venv``). Commands that run
in the ROS 2 venv (``.venv-ros2``: ``--ros2``) find it there too: the hand-off from the main venv
passes its import path in ``$CYBORG_MAIN_PATH`` (:mod:`cyborg.run.ros2_env`), or the checkout's
``.venv`` is looked in; the registry (:mod:`cyborg.app.registry`) puts that path after the ROS 2
venv's own, so nothing there is shadowed. Light: no rclpy is imported here.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

__all__ = ["CHECKOUT", "MAIN_PATH_ENV", "MAIN_PYTHON_ENV", "has_rclpy", "main_path", "main_python"]

CHECKOUT = Path(__file__).resolve().parents[3]
"""The checkout this package runs from (its ``.venv`` and ``.venv-ros2`` live there)."""

MAIN_PATH_ENV = "CYBORG_MAIN_PATH"
"""The main venv's import path (``os.pathsep``-separated), given to a process in the ROS 2 venv:
the module packages installed there are known to ``--ros2`` commands too (see the registry)."""

MAIN_PYTHON_ENV = "CYBORG_MAIN_PYTHON"
"""The main venv's Python, given to a process in the ROS 2 venv: where to pip install a module."""


def has_rclpy() -> bool:
    """True when this interpreter can import rclpy."""
    return importlib.util.find_spec("rclpy") is not None


def main_path() -> list[str]:
    """The main venv's import path when this Python is another one (the ROS 2 venv): the hand-off's
    ``$CYBORG_MAIN_PATH``, else the site-packages of this checkout's ``.venv``; else nothing."""
    given = os.environ.get(MAIN_PATH_ENV)
    if given is not None:
        return [p for p in given.split(os.pathsep) if p and p not in sys.path]
    venv = CHECKOUT / ".venv"
    if not has_rclpy() or Path(sys.prefix).resolve() == venv.resolve():
        return []
    return [str(p) for p in sorted(venv.glob("lib/python*/site-packages")) if str(p) not in sys.path]


def main_python() -> str:
    """The Python a student pip-installs module packages with: the main venv's (also seen by
    ``--ros2`` commands), as the hand-off names it, else this checkout's ``.venv``, else this one."""
    given = os.environ.get(MAIN_PYTHON_ENV)
    if given:
        return given
    candidate = CHECKOUT / ".venv" / "bin" / "python"
    if has_rclpy() and candidate.is_file():
        return str(candidate)
    return sys.executable
