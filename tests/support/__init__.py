"""Helpers the tests share, written once: paths, subprocess runners, the API server, ROS sessions."""
