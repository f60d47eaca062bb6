"""tests/ros2 runs in .venv-ros2 (the ROS 2 wheels): see tests/transport/conftest.py.

In the main venv only test_in_ros2_venv.py is collected here; it runs the rest in a .venv-ros2
process. In that process every test runs on a ROS_DOMAIN_ID of its own, discovery on this host.
"""

from __future__ import annotations

import importlib.util

IN_ROS2_VENV = importlib.util.find_spec("rclpy") is not None

if IN_ROS2_VENV:
    collect_ignore = ["test_in_ros2_venv.py"]
else:
    collect_ignore_glob = ["test_ros2_*.py"]
