"""Who may use the robot's HTTP API, and how much (issue 12, items 1 and 5): an in-process API
on a real socket, driven the way a browser of another site, a DNS-rebinding page, a careless
script or a flood of idle connections would drive it."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable, Callable
from pathlib import Path

import aiohttp
import pytest
from aiohttp import ClientSession, WSServerHandshakeError

from cyborg.app.config import load_config
from cyborg.transport import topics
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String
from cyborg.web.api import RobotAPI
from cyborg.web.security import Access, Limits

MACHINE = """
initial: idle
states:
  idle: {action: cyborg_idle/idle, transitions: {music_play: idle, aborted: idle}}
"""


class Robot:
    """An API on a free port of ``host``, and what reached the robot's topics through it."""

    def __init__(self, api: RobotAPI, url: str) -> None:
        self.api = api
        self.url = url
        self.port = int(url.rstrip("/").rsplit(":", 1)[1])
        self.heard: list[str] = []
        self.switched: list[str] = []


def run(
    tmp_path: Path,
    check: Callable[[Robot, ClientSession], Awaitable[None]],
    *,
    host: str = "127.0.0.1",
    access: Access | None = None,
) -> None:
    config_path = tmp_path / "machine.yaml"
    config_path.write_text(MACHINE)
    config = load_config(config_path)
    clock = RealClock()
    transport = EmbeddedTransport(clock)

    async def main() -> None:
        api = RobotAPI(transport.node("cyborg_api"), machine=config.machine, access=access)
        robot = Robot(api, await api.start(host, 0))
        listener = transport.node("listener")
        listener.subscribe(topics.TEXT_FROM_SPEECH, String, lambda m, i: robot.heard.append(m.data))
        listener.subscribe(topics.EMOTIONAL_CONTROLLER, String, lambda m, i: robot.switched.append(m.data))
        try:
            async with ClientSession(timeout=aiohttp.ClientTimeout(total=20)) as session:
                await check(robot, session)
        finally:
            await api.stop()

    try:
        clock.run(main())
    finally:
        transport.shutdown()
        clock.close()


async def answer(response: aiohttp.ClientResponse) -> tuple[int, str]:
    return response.status, await response.text()


def test_another_site_can_neither_command_the_robot_nor_listen_in(tmp_path: Path) -> None:
    """What a page of another origin can send without a CORS preflight, and a rebinding Host."""

    async def check(robot: Robot, session: ClientSession) -> None:
        url = robot.url.rstrip("/")
        # A "simple request": text/plain or an HTML form, no preflight, the body still JSON-shaped.
        async with session.post(
            url + "/api/emotion/switch", data='{"on": false}', headers={"Content-Type": "text/plain"}
        ) as response:
            status, text = await answer(response)
        assert status == 415 and "only Content-Type: application/json" in text and "fix:" in text
        async with session.post(
            url + "/api/say", data={'{"text": "take me to the cafeteria", "x": "': '"}'}
        ) as r:
            status, text = await answer(r)
        assert status == 415 and "application/x-www-form-urlencoded" in text
        # JSON with the browser's Origin of another site (a port is an origin of its own).
        attacker = f"http://127.0.0.1:{robot.port + 1}"
        async with session.post(
            url + "/api/say", json={"text": "take me to the cafeteria"}, headers={"Origin": attacker}
        ) as response:
            status, text = await answer(response)
        assert status == 403 and attacker in text and f"--allow-origin {attacker}" in text
        # DNS rebinding: the attacker's name resolves to this machine; the Host header gives it away.
        rebound = f"attacker.example:{robot.port}"
        async with session.get(url + "/api/status", headers={"Host": rebound}) as response:
            status, text = await answer(response)
        assert status == 403 and "attacker.example" in text and robot.url in text
        async with session.get(url + "/", headers={"Host": rebound}) as response:
            assert response.status == 403, "the page itself is not served to a rebound name either"
        # The speech stream: a websocket from another origin is refused at the handshake.
        with pytest.raises(WSServerHandshakeError) as refused:
            await session.ws_connect(url + "/api/ws", origin=attacker)
        assert refused.value.status == 403
        await asyncio.sleep(0.2)
        assert robot.heard == [] and robot.switched == [], "nothing reached the robot"

        # The robot's own page (same origin) and tools without an Origin still work.
        async with session.post(
            url + "/api/say", json={"text": "hello"}, headers={"Origin": url}
        ) as response:
            assert response.status == 200, await response.text()
        async with session.post(url + "/api/emotion/switch", json={"on": True}) as response:
            assert response.status == 200
        async with session.ws_connect(url + "/api/ws", origin=url) as ws:
            hello = await ws.receive_json(timeout=5)
        assert hello["type"] == "hello"
        async with session.get(f"http://localhost:{robot.port}/api/status") as response:
            assert response.status == 200, "localhost names the same robot"
        await asyncio.sleep(0.2)
        assert robot.heard == ["hello"] and robot.switched == ["on"]
        assert robot.api.guard.refused == {"content-type": 2, "origin": 2, "host": 2}

    run(tmp_path, check)


def test_beyond_loopback_every_api_request_needs_the_token(tmp_path: Path) -> None:
    async def check(robot: Robot, session: ClientSession) -> None:
        token = robot.api.token
        assert token is not None and len(token) >= 24, "binding every address made a token"
        url = f"http://127.0.0.1:{robot.port}"
        bearer = {"Authorization": f"Bearer {token}"}
        async with session.get(url + "/api/status") as response:
            status, text = await answer(response)
        assert status == 401 and "needs its token" in text and "--token" in text and "#token=" in text
        assert response.headers["WWW-Authenticate"].startswith("Bearer")
        async with session.get(url + "/api/status", headers={"Authorization": "Bearer guessed"}) as response:
            status, text = await answer(response)
        assert status == 401 and "wrong" in text
        async with session.get(url + "/api/status", headers=bearer) as response:
            assert response.status == 200
        async with session.post(url + "/api/say", json={"text": "hello"}, headers=bearer) as response:
            assert response.status == 200
        async with session.get(url + "/") as response:  # no page registered here: 404, not 401
            assert response.status == 404, "outside /api/ (the page, its files) no token is needed"
        with pytest.raises(WSServerHandshakeError) as refused:
            await session.ws_connect(url + "/api/ws")
        assert refused.value.status == 401
        async with session.ws_connect(url + f"/api/ws?token={token}", origin=url) as ws:
            assert (await ws.receive_json(timeout=5))["type"] == "hello"
        # Other machines reach it by an IP literal (which cannot be rebound), not by a foreign name.
        async with session.get(
            url + "/api/status", headers={**bearer, "Host": f"192.0.2.7:{robot.port}"}
        ) as r:
            assert r.status == 200
        async with session.get(
            url + "/api/status", headers={**bearer, "Host": f"evil.example:{robot.port}"}
        ) as r:
            assert r.status == 403
        await asyncio.sleep(0.2)
        assert robot.heard == ["hello"]

    run(tmp_path, check, host="0.0.0.0")


def test_a_given_token_is_required_on_loopback_too_and_allow_origin_trusts_a_proxy(tmp_path: Path) -> None:
    proxy = "https://cyborg.example"
    access = Access(token="t" * 32, allowed_origins=(proxy,))

    async def check(robot: Robot, session: ClientSession) -> None:
        url = robot.url.rstrip("/")
        async with session.get(url + "/api/status") as response:
            assert response.status == 401
        headers = {"Authorization": "Bearer " + "t" * 32, "Origin": proxy, "Host": "cyborg.example"}
        async with session.post(
            url + "/api/say", json={"text": "via the proxy"}, headers=headers
        ) as response:
            assert response.status == 200, await response.text()
        await asyncio.sleep(0.2)
        assert robot.heard == ["via the proxy"]

    run(tmp_path, check, access=access)


def test_oversized_bodies_and_too_many_streams_are_refused_naming_the_limit(tmp_path: Path) -> None:
    access = Access(limits=Limits(max_body=1024, max_websockets=2))

    async def check(robot: Robot, session: ClientSession) -> None:
        url = robot.url.rstrip("/")
        async with session.post(url + "/api/say", json={"text": "x" * 5000}) as response:
            status, text = await answer(response)
        assert status == 413 and "larger than 1024 bytes" in text and "fix:" in text
        first = await session.ws_connect(url + "/api/ws")
        second = await session.ws_connect(url + "/api/ws")
        with pytest.raises(WSServerHandshakeError) as refused:
            await session.ws_connect(url + "/api/ws")
        assert refused.value.status == 503
        await first.close()
        await asyncio.sleep(0.1)
        third = await session.ws_connect(url + "/api/ws")  # room again
        await second.close()
        await third.close()

    run(tmp_path, check, access=access)


Connection = tuple[asyncio.StreamReader, asyncio.StreamWriter]


async def closed_by_server(connection: Connection, within: float) -> bool:
    try:
        data = await asyncio.wait_for(connection[0].read(4096), within)
    except TimeoutError:
        return False
    except ConnectionResetError:
        return True
    return data == b""


def test_idle_connections_make_room_for_a_real_client(tmp_path: Path) -> None:
    """Ten times more idle connections than allowed: a real client is still answered."""
    access = Access(limits=Limits(max_connections=20, header_timeout=60))

    async def check(robot: Robot, session: ClientSession) -> None:
        idle = [await asyncio.open_connection("127.0.0.1", robot.port) for _ in range(200)]
        try:
            closed = await asyncio.gather(*(closed_by_server(c, within=3) for c in idle))
            assert closed.count(False) == 20, "the server holds its limit of 20; the others were refused"
            still_open = [c for c, gone in zip(idle, closed, strict=True) if not gone]
            await asyncio.sleep(robot.api.guard.limits.grace)  # past their grace the 20 count as idle
            before = robot.api.guard.refused.get("idle-closed", 0)
            async with session.get(robot.url + "api/status") as response:
                assert response.status == 200
            assert robot.api.guard.refused["idle-closed"] == before + 1
            made_room = await asyncio.gather(*(closed_by_server(c, within=1) for c in still_open))
            assert made_room.count(True) == 1, "one idle connection made room, the others stay"
        finally:
            for _, writer in idle:
                writer.close()

    run(tmp_path, check, access=access)


def test_a_request_that_never_finishes_its_headers_is_cut_off(tmp_path: Path) -> None:
    access = Access(limits=Limits(header_timeout=0.5))

    async def check(robot: Robot, session: ClientSession) -> None:
        slow = await asyncio.open_connection("127.0.0.1", robot.port)
        slow[1].write(b"GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\n")  # and nothing more
        try:
            assert await closed_by_server(slow, within=10)
            async with session.get(robot.url + "api/status") as response:
                assert response.status == 200
        finally:
            slow[1].close()

    run(tmp_path, check, access=access)


def test_when_every_connection_is_busy_a_new_one_is_told_the_limit(tmp_path: Path) -> None:
    access = Access(limits=Limits(max_connections=3))

    async def check(robot: Robot, session: ClientSession) -> None:
        url = robot.url.rstrip("/")
        streams = [await session.ws_connect(url + "/api/ws") for _ in range(3)]  # each holds its connection
        try:
            async with ClientSession() as other, other.get(url + "/api/status") as response:
                status, text = await answer(response)
            assert status == 503
            assert json.loads(text)["error"].startswith("the robot's API has 3 connections in use, its limit")
            assert "fix: close other dashboards" in text
        finally:
            for stream in streams:
                await stream.close()
        await asyncio.sleep(0.1)
        async with ClientSession() as other, other.get(url + "/api/status") as response:
            assert response.status == 200

    run(tmp_path, check, access=access)
