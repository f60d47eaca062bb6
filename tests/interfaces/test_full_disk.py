"""A robot whose disk is full, seen through the API and the command tool (issue 12, item 4).

The robot is served in this process (`serve_api`, as `cyborg sim` does) so that its store's
disk can fill up on demand (see tests/full_disk.py); the command tool runs as a user runs it.
"""

from __future__ import annotations

import asyncio
import logging
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from aiohttp import ClientSession

from cyborg.app.config import load_config, packaged_config
from cyborg.app.robot import build_robot
from cyborg.motivator.store import ControllerStore
from cyborg.testing.wait import wait_until
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.web.build import serve_api
from full_disk import Disk

CYBORG = [sys.executable, "-m", "cyborg.cli"]
FULL = "database or disk is full"
FIX = "free some space on that disk (or give another folder with --data-dir)"


def tool(url: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*CYBORG, *args, "--url", url], capture_output=True, text=True, timeout=30)


def test_with_the_disk_full_commands_work_in_memory_and_everything_says_it_is_not_saved(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    robot = build_robot(load_config(packaged_config("demo.yaml")), transport, data_dir=tmp_path)
    db = tmp_path / "controller.db"
    disk = Disk(robot.store)
    printed: list[str] = []

    async def main() -> None:
        stop = await serve_api("127.0.0.1", 0, lambda text, **_: printed.append(text))(transport, robot)
        found = re.search(r"(http://127\.0\.0\.1:\d+)/", "\n".join(printed))
        assert found, printed
        url = found.group(1)
        robot.start()
        loop = asyncio.get_running_loop()
        try:
            async with ClientSession() as session:

                async def get(path: str) -> Any:
                    async with session.get(url + path) as response:
                        assert response.status == 200, await response.text()
                        return await response.json()

                async def post(path: str, body: dict[str, Any]) -> Any:
                    async with session.post(url + path, json=body) as response:
                        assert response.status == 200, await response.text()
                        return await response.json()

                status = await get("/api/status")
                assert status["storage"] == {
                    "path": str(db),
                    "saved": True,
                    "problem": None,
                    "fix": None,
                    "failed_writes": 0,
                    "unsaved": [],
                }
                assert "warning" not in await post("/api/emotion/set", {"name": "loved"})
                disk.fill()

                answer = await post("/api/emotion/set", {"name": "angry"})
                assert answer["sent"] == "angry" and answer["saved"] is False
                assert "in memory only" in answer["warning"] and FULL in answer["warning"]

                async def emotion_is(name: str) -> bool:
                    return bool((await get("/api/status"))["emotion"] == name)

                deadline = clock.monotonic() + 10
                while not await emotion_is("angry"):  # the emotion system took it, in memory
                    assert clock.monotonic() < deadline, "the emotion never changed"
                    await asyncio.sleep(0.02)
                answer = await post("/api/emotion/switch", {"on": False})
                assert answer["saved"] is False

                for path in ("/api/status", "/api/health"):
                    storage = (await get(path))["storage"]
                    assert storage["saved"] is False, path
                    assert storage["problem"] == f"could not save the PAD values in {db}: {FULL}"
                    assert storage["fix"] == FIX
                    assert "the PAD values" in storage["unsaved"]
                    assert storage["failed_writes"] >= 2

                shown = await loop.run_in_executor(None, tool, url, "status")
                assert shown.returncode == 0, shown.stderr
                assert "emotion angry" in shown.stdout and "emotion system OFF" in shown.stdout
                assert f"NOT SAVED: could not save the PAD values in {db}: {FULL}" in shown.stdout
                assert f"fix: {FIX}" in shown.stdout
                said = await loop.run_in_executor(None, tool, url, "emotion", "set", "curious")
                assert said.returncode == 0, said.stderr
                assert said.stdout.strip() == "emotion set to curious"
                assert "warning: the robot is not saving its data" in said.stderr
                assert "in memory only" in said.stderr

                assert ControllerStore(db).get_emotion().pad.pleasure > 0, "the full disk took a write"

                disk.free()
                answer = await post(
                    "/api/emotion/values", {"pleasure": -0.25, "arousal": 0.5, "dominance": 0.0}
                )
                assert "saved" not in answer and "warning" not in answer
                assert await wait_until(lambda: robot.store.save_status.saved, clock, timeout=10)
                assert (await get("/api/status"))["storage"]["saved"] is True
                assert (await get("/api/health"))["storage"]["saved"] is True
                shown = await loop.run_in_executor(None, tool, url, "status")
                assert "NOT SAVED" not in shown.stdout
                stored = ControllerStore(db).get_emotion()
                assert stored.pad.as_tuple() == pytest.approx((-0.25, 0.5, 0.0)) and stored.enabled is False
        finally:
            await robot.controller.stop()
            await stop()
            robot.close()

    try:
        clock.run(main())
    finally:
        transport.shutdown()
        clock.close()
    episode = [
        r.getMessage() for r in caplog.records if r.name == "cyborg.storage" and r.levelno >= logging.WARNING
    ]
    assert len(episode) == 2, episode  # one for the full disk, one when writes work again
    assert FULL in episode[0] and "writes work again" in episode[1]
    assert not [r for r in caplog.records if r.exc_info], "a traceback was logged"
