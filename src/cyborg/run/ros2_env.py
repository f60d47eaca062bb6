"""Where ROS 2 runs: the interpreter of ``.venv-ros2`` and the environment of its processes.

ROS 2 lives in its own venv (``scripts/install-ros2``; ROS 1's ``std_msgs`` and the ROS 2
wheels' clash), so a ``--ros2`` command typed in the main venv runs again in ``.venv-ros2``'s
Python (:func:`run_in_ros2_venv`), and ``cyborg launch --ros2`` starts its nodes there. Light:
no rclpy here (``cyborg --help`` and the command tool import this).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from cyborg.app.plugin_path import CHECKOUT, MAIN_PATH_ENV, MAIN_PYTHON_ENV, has_rclpy
from cyborg.errors import CyborgError

__all__ = [
    "PYTHON_ENV",
    "ros2_environment",
    "ros2_python",
    "run_in_ros2_venv",
]

PYTHON_ENV = "CYBORG_ROS2_PYTHON"
"""Names the Python that has rclpy, when it is not this checkout's ``.venv-ros2/bin/python``."""


def ros2_python() -> str:
    """The Python with rclpy: this one, ``$CYBORG_ROS2_PYTHON`` or the checkout's ``.venv-ros2``."""
    if has_rclpy():
        return sys.executable
    given = os.environ.get(PYTHON_ENV)
    candidates = [Path(given)] if given else []
    candidates.append(CHECKOUT / ".venv-ros2" / "bin" / "python")
    for candidate in candidates:
        if candidate.is_file() and os.access(candidate, os.X_OK):
            return str(candidate)
    raise CyborgError(
        f"ROS 2 is not installed: no {candidates[-1]}; fix: run scripts/install-ros2 (it builds "
        f".venv-ros2), or set ${PYTHON_ENV} to a Python that has rclpy"
    )


def ros2_environment() -> dict[str, str]:
    """The environment of a process in the ROS 2 venv: without this venv's PYTHONPATH (ROS 1's
    generated ``cyborg_controller`` would shadow ROS 2's) unless this Python is the ROS 2 one,
    but with this Python's import path in ``$CYBORG_MAIN_PATH``: the module packages installed
    here (pip, or a folder on PYTHONPATH) are found there after the ROS 2 venv's own packages."""
    env = dict(os.environ)
    if not has_rclpy():
        env.pop("PYTHONPATH", None)
        env.pop("VIRTUAL_ENV", None)
        env[MAIN_PATH_ENV] = os.pathsep.join(p for p in sys.path if p and os.path.isdir(p))
        env[MAIN_PYTHON_ENV] = sys.executable
    return env


def run_in_ros2_venv() -> None:
    """Run this command again in the ROS 2 venv's Python, unless this Python has rclpy."""
    if has_rclpy():
        return
    python = ros2_python()
    sys.stdout.flush()
    sys.stderr.flush()
    os.execve(python, [python, "-m", "cyborg.cli", *sys.argv[1:]], ros2_environment())
