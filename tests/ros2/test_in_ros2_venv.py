"""Runs the ROS 2 tests in .venv-ros2, from the main test run (its own venv: see docs/ros2.md).

The ROS 2 half of the contract suite (tests/transport/test_contract.py, ``[ros2]``), the tests
under tests/ros2 and the exception-tree check of the ROS 2 package run in one .venv-ros2 pytest
process, on a random ROS_DOMAIN_ID with discovery kept on this host. This test passes when
that process passed everything and skipped nothing; its output is shown when it did not.

The nested run starts as soon as the main run has collected this test (tests/conftest.py), so
it runs beside the rest of the suite instead of after it: most of its time is waiting for other
processes (discovery, launched nodes), and the main run leaves one of two cores free.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from tests.support.paths import ROOT

VENV_PYTHON = ROOT / ".venv-ros2" / "bin" / "python"
NESTED_TIMEOUT = 900  # seconds for the whole .venv-ros2 run
LANE = pytest.StashKey["NestedLane"]()

# More than the default per-test timeout (pyproject.toml): the nested run has its own, below.
pytestmark = [pytest.mark.ros2, pytest.mark.timeout(NESTED_TIMEOUT + 120)]


class NestedLane:
    """The .venv-ros2 pytest process, started early, its output in a file."""

    def __init__(self, output: Path) -> None:
        env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "_ROS_WHEELS"))}
        env.update(
            ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
            ROS_DOMAIN_ID=str(random.randint(1, 100)),
            PYTHONDONTWRITEBYTECODE="1",
        )
        env.pop("VIRTUAL_ENV", None)
        # The ROS 1 tests put .venv/ros/lib/python (ROS 1's generated cyborg_controller, without
        # the ROS 2 'action' module) on PYTHONPATH for their own processes: it would shadow ROS 2's
        # here. This checkout's code comes first, as in this process (.venv-ros2 may be another
        # checkout's).
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
        self.output = output
        self.started = time.monotonic()
        with output.open("wb") as out:
            self.process = subprocess.Popen(
                command, cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True
            )

    def result(self) -> tuple[int, str]:
        """Wait for the run (at most NESTED_TIMEOUT from its start); its exit code and output."""
        left = NESTED_TIMEOUT - (time.monotonic() - self.started)
        try:
            code = self.process.wait(timeout=max(left, 1.0))
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait()
            code = -signal.SIGKILL
        return code, self.output.read_text(errors="replace")

    def stop(self) -> None:
        """End the run if it is still going (the main run was interrupted)."""
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGTERM)
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()


def start_nested_lane(config: pytest.Config) -> NestedLane | None:
    """Start the nested run now, once per main run, when .venv-ros2 is there."""
    if not VENV_PYTHON.exists():
        return None  # the test says what to do
    lane = config.stash.get(LANE, None)
    if lane is None:
        folder = Path(tempfile.mkdtemp(prefix="cyborg-ros2-lane-"))
        lane = NestedLane(folder / "output.txt")
        config.stash[LANE] = lane
    return lane


def test_ros2_tests_pass_in_their_venv(request: pytest.FixtureRequest) -> None:
    assert VENV_PYTHON.exists(), (
        f"no {VENV_PYTHON}; fix: run scripts/install-ros2 (scripts/setup --test runs it)"
    )
    lane = start_nested_lane(request.config)
    assert lane is not None
    code, output = lane.result()
    sys.stdout.write(output[-4000:])
    assert code == 0, f"the ROS 2 tests failed in .venv-ros2 (exit {code}):\n{output[-6000:]}"
    summary = output.strip().splitlines()[-1]
    assert "passed" in summary and "skipped" not in summary and "failed" not in summary, summary
