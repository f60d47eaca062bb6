"""Issue 31, item 4: a module callback that blocks the in-process robot is named, in the log and on
the dashboard, and the robot carries on once it returns.

Review 11.7: a `time.sleep` in a speech callback froze the controller, emotion, API and dashboard
together and nothing said which module did it. The module here sleeps 3 s per sentence heard.
"""

from __future__ import annotations

import json
import os
import time
import urllib.request
from pathlib import Path

from tests.hostile.robot import ServedRobot

PLUGIN = Path(__file__).parent / "plugins" / "blocking"
JSON = {"Content-Type": "application/json"}


def _post(url: str, body: dict[str, str]) -> None:
    request = urllib.request.Request(url, data=json.dumps(body).encode(), headers=JSON)
    with urllib.request.urlopen(request, timeout=30) as answer:
        assert answer.status == 200


def _get(url: str) -> dict[str, object]:
    with urllib.request.urlopen(url, timeout=30) as answer:
        return dict(json.load(answer))


def test_a_blocking_callback_is_named_and_the_robot_carries_on(tmp_path: Path) -> None:
    path = os.pathsep.join(filter(None, [os.environ.get("PYTHONPATH"), str(PLUGIN)]))
    robot = ServedRobot(
        tmp_path,
        "--config",
        str(PLUGIN / "robot.yaml"),
        "--data-dir",
        str(tmp_path / "data"),
        env={"PYTHONPATH": path},
    )
    try:
        _post(robot.url + "/api/say", {"text": "hello there"})  # the module sleeps 3 s on it
        _post(robot.url + "/api/event", {"name": "music_play"})  # waits for the loop, then is taken
        deadline = time.monotonic() + 30
        while "turns again" not in robot.text() or "--music_play--> music" not in robot.text():
            assert time.monotonic() < deadline, robot.text()
            time.sleep(0.2)
        warning = next(line for line in robot.text().splitlines() if "the robot is blocked" in line)
        assert "Blocking.heard (module cyborg_slow, " in warning and "hostile_blocking.py:23" in warning, (
            warning
        )
        assert "asyncio.to_thread" in warning, warning
        blocked = _get(robot.url + "/api/health")["blocked"]
        assert isinstance(blocked, dict), blocked
        assert blocked["callback"] == "Blocking.heard" and blocked["module"] == "cyborg_slow", blocked
        assert blocked["ongoing"] is False and 2.0 <= float(blocked["seconds"]) <= 10, blocked
        assert robot.terminate() == 0, robot.text()
    finally:
        robot.kill()
