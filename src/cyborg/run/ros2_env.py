"""Where ROS 2 runs: the interpreter of ``.venv-ros2`` and the environment of its processes.

ROS 2 lives in its own venv (``scripts/install-ros2``; ROS 1's ``std_msgs`` and the ROS 2
wheels' clash), so a ``--ros2`` command typed in the main venv runs again in ``.venv-ros2``'s
Python (:func:`run_in_ros2_venv`), and ``cyborg launch --ros2`` starts its nodes there. Light:
no rclpy here (``cyborg --help`` and the command tool import this).
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

from cyborg.errors import CyborgError

__all__ = [
    "MAIN_PATH_ENV",
    "MAIN_PYTHON_ENV",
    "PYTHON_ENV",
    "has_rclpy",
    "main_path",
    "main_python",
    "ros2_environment",
    "ros2_python",
    "run_in_ros2_venv",
]

PYTHON_ENV = "CYBORG_ROS2_PYTHON"
"""Names the Python that has rclpy, when it is not this checkout's ``.venv-ros2/bin/python``."""

MAIN_PATH_ENV = "CYBORG_MAIN_PATH"
"""The main venv's import path (``os.pathsep``-separated), given to a process in the ROS 2 venv:
the module packages installed there are known to ``--ros2`` commands too (see the registry)."""

MAIN_PYTHON_ENV = "CYBORG_MAIN_PYTHON"
"""The main venv's Python, given to a process in the ROS 2 venv: where to pip install a module."""

CHECKOUT = Path(__file__).resolve().parents[3]


def has_rclpy() -> bool:
    """True when this interpreter can import rclpy."""
    return importlib.util.find_spec("rclpy") is not None


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


def run_in_ros2_venv() -> None:
    """Run this command again in the ROS 2 venv's Python, unless this Python has rclpy."""
    if has_rclpy():
        return
    python = ros2_python()
    sys.stdout.flush()
    sys.stderr.flush()
    os.execve(python, [python, "-m", "cyborg.cli", *sys.argv[1:]], ros2_environment())
