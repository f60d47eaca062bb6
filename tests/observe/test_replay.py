"""``cyborg replay``: the API answers as the robot's would have at a chosen moment, and the page's
time slider shows that moment (a real Chromium drags it)."""

from __future__ import annotations

import asyncio
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from aiohttp.test_utils import TestClient, TestServer

from cyborg.observe.recording import open_recording
from cyborg.web.replay import ReplayAPI


def ask(api: ReplayAPI, *paths: str) -> list[tuple[int, Any]]:
    async def main() -> list[tuple[int, Any]]:
        async with TestClient(TestServer(api.app)) as client:
            out = []
            for path in paths:
                response = await client.get(path)
                body: Any
                if response.status != 200:
                    body = await response.text()
                elif response.content_type == "application/json":
                    body = await response.json()
                else:
                    body = await response.read()
                out.append((response.status, body))
            return out

    return asyncio.run(main())


def test_the_replay_api_answers_as_at_that_moment(d_run: tuple[Path, Path, str], tmp_path: Path) -> None:
    transcript, recording, _ = d_run
    import json

    records = [json.loads(line) for line in transcript.read_text().splitlines()]
    entered = next(r for r in records if r["type"] == "state" and r["to"] == "conversation")
    api = ReplayAPI(open_recording(recording))
    just_before = entered["t_ns"] / 1e9 - 0.001
    [(s1, before), (s2, at), (s3, bad), (s4, log)] = ask(
        api,
        f"/api/status?at={just_before}",
        f"/api/status?at={entered['t']}",
        "/api/status?at=soon",
        f"/api/records?at={entered['t']}",
    )
    assert (s1, s2, s4) == (200, 200, 200)
    assert before["state"] != "conversation" and at["state"] == "conversation"
    assert at["previous_state"] == entered["from"] and at["event"] == entered["event"]
    emotion = [r for r in records if r["type"] == "emotion" and r["t_ns"] <= entered["t_ns"]][-1]
    assert (at["emotion"], at["pleasure"]) == (emotion["emotion"], emotion["pleasure"])
    assert s3 == 400 and "'at' must be seconds" in bad
    assert log[-1] == entered or log[-1]["t_ns"] == entered["t_ns"]
    assert all(r["t_ns"] <= entered["t_ns"] for r in log)
    # Served from a glance at the file: the start is answered from a window, the rest once read.
    early = ReplayAPI.of_file(recording)
    assert early.view is None
    [(_, first), (_, loading), (_, start), (_, whole), (status, about), (png_status, png)] = ask(
        early,
        "/api/replay",
        f"/api/status?at={just_before}",
        "/api/records?at=30",
        "/api/replay?wait=1",
        "/api/map",
        "/api/map.png",
    )
    assert first["loading"] is True and first["duration"] >= records[-1]["t"]
    assert loading == before, "a moment early on is answered before the recording is read whole"
    assert api.view is not None
    assert start == api.view.records_at(30_000_000_000), "the window holds what the whole file does"
    assert whole["loading"] is False and whole["records"] == len(records)
    # The map the robot ran on, from the recording (drawn behind the track).
    assert (status, png_status) == (200, 200) and png[:4] == b"\x89PNG"
    assert about["cells"][0] > 100 and about["resolution"] > 0
    assert "cafeteria" in {place["name"] for place in about["locations"]}


@pytest.mark.browser
def test_dragging_the_slider_shows_that_moment(d_run: tuple[Path, Path, str], tmp_path: Path) -> None:
    from playwright.sync_api import sync_playwright

    from tests.dashboard.test_dashboard_browser import CHROMIUM, CHROMIUM_ARGS

    _, recording, _ = d_run
    out = (tmp_path / "replay.log").open("w")
    began = time.monotonic()
    process = subprocess.Popen(
        [sys.executable, "-m", "cyborg.cli", "replay", str(recording), "--port", "0"],
        stdout=out,
        stderr=subprocess.STDOUT,
    )
    try:
        url = None
        while url is None and time.monotonic() - began < 30:
            found = re.search(r"http://\S+/", (tmp_path / "replay.log").read_text())
            url = found.group(0) if found else None
            time.sleep(0.1)
        assert url, (tmp_path / "replay.log").read_text()
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1200, "height": 800})
            page.goto(url)
            page.wait_for_selector("body[data-shown='0']")
            assert page.inner_text("#state") == "idle"
            page.wait_for_selector("body[data-loaded]")
            slider = page.locator("#slider").bounding_box()
            assert slider is not None
            page.mouse.move(slider["x"] + 2, slider["y"] + slider["height"] / 2)
            page.mouse.down()
            page.mouse.move(slider["x"] + slider["width"] * 0.5, slider["y"] + slider["height"] / 2, steps=5)
            page.mouse.up()
            page.wait_for_function("Number(document.body.dataset.shown) > 60")
            shown = float(page.get_attribute("body", "data-shown") or 0)
            page.wait_for_selector("body[data-map='drawn']")  # the recorded map behind the track
            page.wait_for_selector("body[data-graph='drawn']")  # the recorded machine, its state lit
            page.screenshot(path=str(Path("/tmp") / "replay-dragged.png"))
            api = ReplayAPI(open_recording(recording))
            expected = api.status_at(round(shown * 1e9))
            assert page.inner_text("#state") == expected["state"]
            assert page.inner_text("#emotion") == expected["emotion"]
            lit = page.evaluate("document.querySelector('#graph .node.active')?.id")
            assert lit == f"state:{expected['state']}", "the graph shows the state at the slider's moment"
            assert page.locator("#log li").count() > 0
            log_times = [float(t) for t in page.locator("#log .t").all_inner_texts()]
            assert max(log_times) <= shown + 0.05, "the log shows nothing after the slider's moment"
            page.click("#play")
            page.wait_for_function(f"Number(document.body.dataset.shown) > {shown + 1}")
            page.click("#play")
            browser.close()
    finally:
        process.terminate()
        process.wait(timeout=10)
        out.close()
