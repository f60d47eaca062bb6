"""`cyborg sim` as a service and on a network (issue 12, items 1, 5 and 8): the signal a service
manager sends, a flood of idle connections under the usual open-file limit, and serving beyond
loopback with the token it prints, used by the command tool."""

from __future__ import annotations

import asyncio
import os
import re
import resource
import signal
import subprocess
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import aiohttp
import pytest

from cyborg.app.config import packaged_config
from tests.support.tools import CYBORG, tool

ADDRESS = re.compile(r"dashboard and API: (http://127\.0\.0\.1:(\d+))/(#token=(\S+))?")


class RunningSim:
    """`cyborg sim` with the demo robot; its output goes to a file we read."""

    def __init__(self, data: Path, *extra: str, files: int | None = None) -> None:
        self.output = data / "sim.log"

        def limit_files() -> None:  # in the child only: the usual soft limit of a login shell
            if files is not None:
                hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
                resource.setrlimit(resource.RLIMIT_NOFILE, (files, hard))

        with self.output.open("w") as out:
            config = str(packaged_config("demo.yaml"))
            self.process = subprocess.Popen(
                [*CYBORG, "sim", "--config", config, "--port", "0", "--db", str(data), *extra],
                stdout=out,
                stderr=subprocess.STDOUT,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
                preexec_fn=limit_files,
            )
        deadline = time.monotonic() + 30
        match = None
        while match is None and time.monotonic() < deadline and self.process.poll() is None:
            time.sleep(0.05)
            match = ADDRESS.search(self.text())
        if match is None:
            self.stop()
            pytest.fail("`cyborg sim` did not print its address; its output:\n" + self.text())
        self.url, self.port, self.token = match.group(1), int(match.group(2)), match.group(4)

    def text(self) -> str:
        return self.output.read_text()

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait(timeout=10)


@pytest.fixture
def sims(tmp_path: Path) -> Iterator[list[RunningSim]]:
    started: list[RunningSim] = []
    yield started
    for sim in started:
        sim.stop()


def test_sigterm_stops_the_sim_as_gracefully_as_its_duration_does(
    sims: list[RunningSim], tmp_path: Path
) -> None:
    """What systemd, docker or `kill` send: the robot stops its controller, tells live clients
    it is going away, exits 0."""
    sim = RunningSim(tmp_path)
    sims.append(sim)

    async def follow_then_terminate() -> tuple[int | None, str]:
        async with aiohttp.ClientSession() as session, session.ws_connect(sim.url + "/api/ws") as socket:
            assert (await socket.receive_json(timeout=10))["type"] == "hello"
            sim.process.send_signal(signal.SIGTERM)
            while True:
                message = await socket.receive(timeout=20)
                if message.type in (
                    aiohttp.WSMsgType.CLOSE,
                    aiohttp.WSMsgType.CLOSED,
                    aiohttp.WSMsgType.ERROR,
                ):
                    return socket.close_code, str(message.extra or "")

    code, reason = asyncio.run(follow_then_terminate())
    assert sim.process.wait(timeout=20) == 0, sim.text()
    assert code == aiohttp.WSCloseCode.GOING_AWAY and reason == "the robot stopped"
    lines = sim.text().splitlines()
    assert any(line.endswith("SIGTERM: stopping") for line in lines) and lines[-1] == "stopped", lines[-5:]


def test_a_thousand_idle_connections_under_the_usual_file_limit_lock_nobody_out(
    sims: list[RunningSim], tmp_path: Path
) -> None:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, min(hard, 4096)), hard))  # this side needs 1,100
    sim = RunningSim(tmp_path, files=1024)
    sims.append(sim)

    async def flood_then_ask() -> int:
        idle = [await asyncio.open_connection("127.0.0.1", sim.port) for _ in range(1100)]
        try:
            await asyncio.sleep(1.5)  # idle, not just opened
            timeout = aiohttp.ClientTimeout(total=10)
            async with (
                aiohttp.ClientSession(timeout=timeout) as session,
                session.get(sim.url + "/api/status") as response,
            ):
                return response.status
        finally:
            for _, writer in idle:
                writer.close()

    try:
        status = asyncio.run(flood_then_ask())
    finally:
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    assert status == 200


def test_beyond_loopback_the_sim_warns_and_prints_the_token_the_tool_needs(
    sims: list[RunningSim], tmp_path: Path
) -> None:
    sim = RunningSim(tmp_path, "--host", "0.0.0.0")
    sims.append(sim)
    output = sim.text()
    assert "warning: serving on 0.0.0.0" in output and "docs/security.md" in output
    assert sim.token is not None and len(sim.token) >= 24
    assert f"CYBORG_TOKEN={sim.token} cyborg status --url {sim.url}" in output

    refused = tool(sim.url, "status")
    assert refused.returncode != 0
    assert "needs its token" in refused.stderr and "--token" in refused.stderr
    with pytest.raises(urllib.error.HTTPError) as info:
        urllib.request.urlopen(sim.url + "/api/status", timeout=10)
    assert info.value.code == 401

    assert tool(sim.url, "status", "--token", sim.token).returncode == 0
    said = tool(sim.url, "say", "hello", env={"CYBORG_TOKEN": sim.token})
    assert said.returncode == 0 and said.stdout.strip() == "heard: hello", said.stderr


def test_a_token_given_by_the_operator_is_used_and_a_short_one_refused(
    sims: list[RunningSim], tmp_path: Path
) -> None:
    short = subprocess.run(
        [*CYBORG, "sim", "--token", "abc", "--duration", "1"], capture_output=True, text=True
    )
    assert short.returncode != 0 and "shorter than 16 characters" in short.stderr
    token = "operator-chosen-token-0123456789"
    sim = RunningSim(tmp_path, "--token", token)
    sims.append(sim)
    assert sim.token == token and "token generated" not in sim.text()
    assert tool(sim.url, "status").returncode != 0
    assert tool(sim.url, "status", env={"CYBORG_TOKEN": token}).returncode == 0
