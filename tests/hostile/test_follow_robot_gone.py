"""Review 9.7: `cyborg status --follow` exited 0 without a word when the robot stopped or died."""

from __future__ import annotations

import os
import subprocess
import threading
import time
import urllib.request
from pathlib import Path

from tests.hostile.robot import ServedRobot
from tests.support.tools import CYBORG


def test_status_follow_says_the_robot_stopped_and_exits_non_zero(tmp_path: Path) -> None:
    robot = ServedRobot(tmp_path, "--data-dir", str(tmp_path / "data"))
    follower = subprocess.Popen(
        [*CYBORG, "status", "--follow", "--url", robot.url],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "NO_COLOR": "1"},
    )
    try:
        assert follower.stdout is not None
        follower.stdout.readline()  # the status, read before the stream opens
        request = urllib.request.Request(
            robot.url + "/api/event",
            data=b'{"name": "music_play"}',
            headers={"Content-Type": "application/json"},
        )
        live = threading.Event()

        def ask_for_music() -> None:  # until a state change has come over the live stream
            while not live.wait(1.0):
                urllib.request.urlopen(request, timeout=10).close()

        asker = threading.Thread(target=ask_for_music, daemon=True)
        asker.start()
        deadline = time.monotonic() + 60
        while "music" not in follower.stdout.readline():
            assert time.monotonic() < deadline
        live.set()
        asker.join()
        assert robot.terminate() == 0, robot.text()
        rest, _ = follower.communicate(timeout=30)
    finally:
        robot.kill()
        if follower.poll() is None:
            follower.kill()
    assert follower.returncode == 1, rest
    assert f"the robot at {robot.url} stopped" in rest and "Traceback" not in rest, rest
