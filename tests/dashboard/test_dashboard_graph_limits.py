"""The dashboard's state machine drawing under load (issue 12, item 5; issue 16): the machine is
laid out once per machine, each Graphviz run within a time and memory cap, is stopped with the
robot, and a machine too big to lay out is shown as a readable list. A stand-in ``dot`` on PATH
records each run and hands it to the real one (or hangs)."""

from __future__ import annotations

import asyncio
import os
import re
import shutil
import stat
import sys
import time
from collections.abc import Awaitable, Callable
from pathlib import Path

import aiohttp
import pytest

from cyborg.app.config import load_config
from cyborg.drawing.layout import DIRECTIONS
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.web import api as api_module
from cyborg.web.api import RobotAPI

FAKE_DOT = """#!{python}
import os, resource, subprocess, sys, time
source = sys.stdin.buffer.read()  # as dot does: nothing is laid out before the input is in
with open(os.environ["FAKE_DOT_LOG"], "a") as log:
    log.write(f"{{os.getpid()}} {{resource.getrlimit(resource.RLIMIT_AS)[0]}}\\n")
if os.environ.get("FAKE_DOT_HANG"):
    time.sleep(3600)
time.sleep(0.5)
sys.stdout.buffer.write(subprocess.run(["{dot}", *sys.argv[1:]], input=source, capture_output=True).stdout)
"""


def machine_yaml(states: int) -> str:
    lines = ["initial: s0", "states:"]
    for i in range(states):
        lines.append(f"  s{i}: {{action: m/a, transitions: {{next: s{(i + 1) % states}, aborted: s0}}}}")
    return "\n".join(lines) + "\n"


@pytest.fixture
def fake_dot(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A ``dot`` first on PATH that logs "pid address-space-limit" per run; returns the log."""
    folder = tmp_path / "bin"
    folder.mkdir()
    dot = folder / "dot"
    real = shutil.which("dot")
    assert real, "Graphviz's dot is missing; fix: scripts/install-system-deps"
    dot.write_text(FAKE_DOT.format(python=sys.executable, dot=real))
    dot.chmod(dot.stat().st_mode | stat.S_IEXEC)
    log = tmp_path / "dot.log"
    log.touch()
    monkeypatch.setenv("PATH", f"{folder}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.setenv("FAKE_DOT_LOG", str(log))
    monkeypatch.setattr(api_module, "_DRAWINGS", {})  # no drawing from an earlier test
    return log


def runs(log: Path) -> list[tuple[int, int]]:
    return [(int(pid), int(limit)) for pid, limit in (line.split() for line in log.read_text().splitlines())]


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return not Path(f"/proc/{pid}/stat").read_text().split(") ")[1].startswith("Z")


Check = Callable[[RobotAPI, str, aiohttp.ClientSession], Awaitable[None]]


def serve(tmp_path: Path, states: int, check: Check) -> None:
    path = tmp_path / "machine.yaml"
    path.write_text(machine_yaml(states))
    machine = load_config(path).machine
    clock = RealClock()
    transport = EmbeddedTransport(clock)

    async def main() -> None:
        api = RobotAPI(transport.node("cyborg_api"), machine=machine)
        url = (await api.start("127.0.0.1", 0)).rstrip("/")
        try:
            async with aiohttp.ClientSession(timeout=aiohttp.ClientTimeout(total=30)) as session:
                await check(api, url, session)
        finally:
            await api.stop()

    try:
        clock.run(main())
    finally:
        transport.shutdown()
        clock.close()


def test_many_requests_share_one_layout_run_under_a_memory_cap(tmp_path: Path, fake_dot: Path) -> None:
    async def check(api: RobotAPI, url: str, session: aiohttp.ClientSession) -> None:
        async def graph() -> tuple[int, str, bytes]:
            async with session.get(url + "/api/graph.svg") as response:
                return response.status, response.headers.get("X-Graph-Layout", ""), await response.read()

        answers = await asyncio.gather(*(graph() for _ in range(8)))  # eight dashboards open at once
        answers.append(await graph())  # and one later
        # one layout: a flat machine is one block, laid out in each direction by its own dot
        assert len(runs(fake_dot)) == len(DIRECTIONS), f"{len(runs(fake_dot))} dot runs for one flat machine"
        assert {a[:2] for a in answers} == {(200, "graphviz")} and len({a[2] for a in answers}) == 1
        assert 'id="state:s3"' in answers[0][2].decode()
        assert {limit for _, limit in runs(fake_dot)} == {api_module.GRAPH_MEMORY}, (
            "their address space is capped"
        )

    serve(tmp_path, 5, check)


def test_a_layout_past_the_time_cap_is_stopped_and_the_machine_listed(
    tmp_path: Path, fake_dot: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FAKE_DOT_HANG", "1")
    monkeypatch.setattr(api_module, "GRAPH_TIMEOUT", 1.0, raising=False)

    async def check(api: RobotAPI, url: str, session: aiohttp.ClientSession) -> None:
        async with session.get(url + "/api/graph.svg") as response:
            svg = (await response.read()).decode()
            assert response.status == 200 and response.headers["X-Graph-Layout"] == "list"
        assert "longer than 1 s (the limit)" in svg and "cyborg graph FILE -o machine.svg" in svg
        assert svg.count('class="node"') == 5 and 'id="state:s3"' in svg and "next \u2192 s4" in svg
        pids = [pid for pid, _ in runs(fake_dot)]
        assert len(pids) == len(DIRECTIONS)
        assert not any(alive(pid) for pid in pids), "the layout that ran too long was stopped"

    serve(tmp_path, 5, check)


def test_stopping_the_robot_stops_a_layout_in_progress(
    tmp_path: Path, fake_dot: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FAKE_DOT_HANG", "1")
    started: list[int] = []

    async def check(api: RobotAPI, url: str, session: aiohttp.ClientSession) -> None:
        request = asyncio.ensure_future(session.get(url + "/api/graph.svg"))
        for _ in range(200):
            if len(runs(fake_dot)) == len(DIRECTIONS):
                break
            await asyncio.sleep(0.05)
        started.extend(pid for pid, _ in runs(fake_dot))
        assert len(started) == len(DIRECTIONS), "the layout is running, one dot per direction"
        request.cancel()

    serve(tmp_path, 5, check)  # leaving serve() stops the API
    deadline = time.monotonic() + 10
    while any(alive(pid) for pid in started) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(alive(pid) for pid in started), "Graphviz was left running after the robot stopped"


def test_a_huge_machine_is_listed_without_running_graphviz(
    tmp_path: Path, fake_dot: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    states = 500
    monkeypatch.setattr(api_module, "GRAPH_MAX_STATES", 200)

    async def check(api: RobotAPI, url: str, session: aiohttp.ClientSession) -> None:
        async with session.get(url + "/api/graph.svg") as response:
            svg = (await response.read()).decode()
            assert runs(fake_dot) == [], "Graphviz was not even started"
            assert response.status == 200 and response.headers["X-Graph-Layout"] == "list"
        note = re.search(r"<text[^>]*>([^<]*)</text>", svg)
        assert note is not None
        assert note.group(1).startswith(f"{states} states: more than the {api_module.GRAPH_MAX_STATES}")
        assert "Fix: draw it offline" in note.group(1)
        assert svg.count('class="node"') == states and 'id="state:s499"' in svg

    serve(tmp_path, states, check)
