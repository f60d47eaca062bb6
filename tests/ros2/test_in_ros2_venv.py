"""Runs the ROS 2 tests in .venv-ros2, from the main test run (its own venv: see docs/ros2.md).

The ROS 2 half of the contract suite (tests/transport/test_contract.py, ``[ros2]``), the tests
under tests/ros2 and the exception-tree check of the ROS 2 package run in one .venv-ros2 pytest
process, on a random ROS_DOMAIN_ID with discovery kept on this host. This test passes when
that process passed everything and skipped nothing; its output is shown when it did not.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys

import pytest

from tests.support.paths import ROOT

VENV_PYTHON = ROOT / ".venv-ros2" / "bin" / "python"
NESTED_TIMEOUT = 900  # seconds for the whole .venv-ros2 run

# More than the default per-test timeout (pyproject.toml): the nested run has its own, below.
pytestmark = [pytest.mark.ros2, pytest.mark.timeout(NESTED_TIMEOUT + 120)]


def test_ros2_tests_pass_in_their_venv() -> None:
    assert VENV_PYTHON.exists(), (
        f"no {VENV_PYTHON}; fix: run scripts/install-ros2 (scripts/setup --test runs it)"
    )
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "_ROS_WHEELS"))}
    env.update(
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_DOMAIN_ID=str(random.randint(1, 100)),
        PYTHONDONTWRITEBYTECODE="1",
    )
    env.pop("VIRTUAL_ENV", None)
    # The ROS 1 tests put .venv/ros/lib/python (ROS 1's generated cyborg_controller, without the
    # ROS 2 'action' module) on PYTHONPATH for their own processes: it would shadow ROS 2's here.
    # This checkout's code comes first, as in this process (.venv-ros2 may be another checkout's).
    env["PYTHONPATH"] = str(ROOT / "src")
    command = [
        str(VENV_PYTHON),
        "-m",
        "pytest",
        "-p",
        "no:cacheprovider",
        "-q",
        "-W",
        "ignore::DeprecationWarning",
        "tests/transport/test_contract.py",
        "tests/ros2",
        "tests/test_errors.py::test_every_exception_class_is_in_the_tree_or_says_why_not",
        "-k",
        "ros2",
    ]
    done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True, timeout=NESTED_TIMEOUT)
    output = done.stdout + done.stderr
    sys.stdout.write(output[-4000:])
    assert done.returncode == 0, f"the ROS 2 tests failed in .venv-ros2:\n{output[-6000:]}"
    summary = output.strip().splitlines()[-1]
    assert "passed" in summary and "skipped" not in summary and "failed" not in summary, summary
