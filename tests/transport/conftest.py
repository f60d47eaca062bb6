"""Which transports' contract tests run in this process.

The ROS 1 transport needs the main venv (.venv, Debian's rospy), the ROS 2 transport its own
(.venv-ros2, the ROS 2 wheels): both install a top-level ``std_msgs``. So the main run leaves
out the ``[ros2]`` cases here, and tests/ros2/test_in_ros2_venv.py runs them (and tests/ros2)
in a .venv-ros2 process; that process leaves out the ``[ros]`` (ROS 1) cases. Nothing is
skipped: each case runs in the one venv it can run in.
"""

from __future__ import annotations

import importlib.util

import pytest

IN_ROS2_VENV = importlib.util.find_spec("rclpy") is not None


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    keep, gone = [], []
    for item in items:
        params = getattr(getattr(item, "callspec", None), "params", {})
        transport = params.get("graph")
        if transport is not None and transport != "embedded" and (transport == "ros2") != IN_ROS2_VENV:
            gone.append(item)
        else:
            keep.append(item)
    if gone:
        config.hook.pytest_deselected(items=gone)
        items[:] = keep
