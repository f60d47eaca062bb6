"""The dashboard in a real headless Chromium against `cyborg sim` (the default Cyborg), as a user sees it.

One robot (virtual time at a few times real speed) and one browser serve all tests
here; each test opens its own page and fails on any console error. Screenshots
go to /tmp/cyborg-dashboard-*.png. Needs the `playwright` package (dev extras)
and the system Chromium (`scripts/install-system-deps --test`); no browser is
downloaded.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser, ConsoleMessage, Page, expect, sync_playwright

from cyborg.interfaces.cli import packaged_config

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-quic",
    "--no-first-run",
    "--disable-component-update",
    "--disable-sync",
]
SPEED = "2"  # virtual seconds per real second: the robot acts sooner and the base drives faster
SHOTS = Path("/tmp")
CYBORG = [sys.executable, "-m", "cyborg.interfaces.cli"]
NOTHING = "\u2013"  # what the page shows before it knows a value


class Sim:
    """One `cyborg sim` process with the packaged Cyborg; its output goes to a file (never blocks)."""

    def __init__(self, data: Path, port: int = 0, config: Path | None = None) -> None:
        data.mkdir(parents=True, exist_ok=True)
        self.output = data / "sim.log"
        chosen = ["--config", str(config)] if config else []
        with self.output.open("w") as out:
            self.process = subprocess.Popen(
                [*CYBORG, "sim", "--port", str(port), "--db", str(data), "--speed", SPEED, *chosen],
                stdout=out,
                stderr=subprocess.STDOUT,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
        deadline = time.monotonic() + 20
        match = None
        while match is None and time.monotonic() < deadline and self.process.poll() is None:
            time.sleep(0.05)
            match = re.search(r"(http://127\.0\.0\.1:(\d+))/", self.output.read_text())
        if match is None:
            self.stop()
            pytest.fail("`cyborg sim` did not print its address; its output:\n" + self.output.read_text())
        self.url = match.group(1)
        self.port = int(match.group(2))

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The robot all page tests share; yields its base URL."""
    robot = Sim(tmp_path_factory.mktemp("dashboard-data"))
    try:
        yield robot.url
    finally:
        robot.stop()


def open_page(browser: Browser, url: str, errors: list[str]) -> Page:
    """A 1400x900 page on ``url`` that appends its console errors to ``errors``."""
    tab = browser.new_context(viewport={"width": 1400, "height": 900}).new_page()
    tab.set_default_timeout(15_000)

    def on_console(message: ConsoleMessage) -> None:
        if message.type == "error":
            errors.append(f"console: {message.text}")

    tab.on("console", on_console)
    tab.on("pageerror", lambda error: errors.append(f"page error: {error}"))
    tab.goto(url)
    return tab


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    assert shutil.which(CHROMIUM), f"{CHROMIUM} is missing; fix: scripts/install-system-deps --test"
    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield chromium
        chromium.close()


@pytest.fixture
def page(browser: Browser, sim: str) -> Iterator[Page]:
    """The dashboard, loaded and live; the test fails if the page logs an error."""
    errors: list[str] = []
    tab = open_page(browser, sim + "/", errors)
    expect(tab.locator("#conn")).to_have_attribute("data-state", "open")
    expect(tab.locator("#graph svg")).to_be_visible()
    yield tab
    tab.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def go_idle(page: Page, sim: str) -> None:
    """Bring the robot back to idle (it wanders off by itself): send events that lead there."""
    machine = page.request.get(sim + "/api/machine").json()
    states = {state["name"]: state for state in machine["states"]}
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        status = page.request.get(sim + "/api/status").json()
        if status["state"] == "idle":
            return
        toward_idle = "aborted"
        name: str | None = status["state"]
        while name is not None:  # a transition of the state or of a superstate around it
            found = [e for e, target in states[name]["transitions"].items() if target == "idle"]
            if found:
                toward_idle = found[0]
                break
            name = states[name]["parent"]
        page.request.post(sim + "/api/event", data={"name": toward_idle})
        page.wait_for_timeout(150)
    raise AssertionError(f"the robot did not get back to idle; it is in {status['state']}")


def visible_log_types(page: Page) -> set[str]:
    return set(page.locator("#log li").evaluate_all("rows => rows.map(r => r.dataset.type)"))


def log_entries(page: Page, kind: str) -> list[str]:
    return page.locator(f'#log li[data-type="{kind}"] .text').all_inner_texts()


def active_state(page: Page) -> str | None:
    found: str | None = page.evaluate(
        "() => { const n = document.querySelector('#graph .node.active'); return n ? n.id : null; }"
    )
    return found


def test_page_loads_live_without_errors(page: Page, sim: str) -> None:
    expect(page.locator("#top-state")).not_to_have_text(NOTHING)
    state = page.locator("#top-state").inner_text()
    assert active_state(page) == f"state:{state}", "the graph highlights the active state"
    expect(page.locator("#health-table tbody tr").first).to_be_visible()
    expect(page.locator('#health-table tr[data-module="cyborg_idle"]')).to_be_visible()
    expect(page.locator("#emotion-name")).not_to_have_text(NOTHING)
    expect(page.locator("#emotion-select option")).to_have_count(10)  # neutral + nine prototypes
    assert any("start" in entry for entry in log_entries(page, "state")), "the log shows the start"
    page.wait_for_timeout(500)  # let the plots draw once
    page.screenshot(path=str(SHOTS / "cyborg-dashboard-load.png"))
    alias = page.request.get(sim + "/dashboard")
    assert alias.ok and "<title>Cyborg dashboard</title>" in alias.text()


def test_event_button_moves_the_highlight(page: Page, sim: str) -> None:
    go_idle(page, sim)
    button = page.locator('#event-buttons button[data-event="music_play"]')
    button.click()
    page.wait_for_function("() => document.getElementById('state:music')?.classList.contains('active')")
    assert page.evaluate("() => document.getElementById('edge:idle:music_play').classList.contains('last')")
    expect(page.locator("#top-state")).to_have_text("music")
    expect(page.locator("#events-state")).to_have_text("music")
    expect(page.locator('#event-buttons button[data-event="conversation_interest"]')).to_be_visible()
    assert "idle —music_play→ music" in log_entries(page, "state")
    page.screenshot(path=str(SHOTS / "cyborg-dashboard-event.png"))


def test_chat_leads_to_speech_in_the_log(page: Page) -> None:
    said_before = len(log_entries(page, "say"))
    for text in ("hello", "Where is the cafeteria?"):
        page.fill("#chat-input", text)
        page.press("#chat-input", "Enter")
        expect(page.locator('#log li[data-type="heard"] .text', has_text=text)).to_have_count(1)
        expect(page.locator("#chat-input")).to_have_value("")
    page.wait_for_function(
        f"() => document.querySelectorAll('#log li[data-type=\"say\"]').length > {said_before}",
        timeout=20_000,
    )
    page.wait_for_timeout(300)
    page.screenshot(path=str(SHOTS / "cyborg-dashboard-chat.png"))

    # The log's filters: by type (checkboxes) and by text.
    assert {"state", "say", "heard"} <= visible_log_types(page)
    page.locator('.log-filters input[data-type="say"]').uncheck()
    assert "say" not in visible_log_types(page) and "heard" in visible_log_types(page)
    page.locator('.log-filters input[data-type="say"]').check()
    page.fill("#log-text", "cafeteria")
    texts = page.locator("#log li .text").all_inner_texts()
    assert texts and all("cafeteria" in text.lower() for text in texts)
    page.fill("#log-text", "")
    assert "state" in visible_log_types(page)


def test_emotion_set_and_switch(page: Page, sim: str) -> None:
    page.select_option("#emotion-select", "happy")
    page.click("#emotion-set")
    expect(page.locator("#emotion-name")).to_have_text("happy")
    expect(page.locator("#val-p")).to_have_text("+0.50")
    page.locator("#emotion-switch").uncheck()
    expect(page.locator("#emotion-switch-state")).to_have_text("switched off")
    assert page.request.get(sim + "/api/health").json()["emotion_enabled"] is False
    page.locator("#emotion-switch").check()
    expect(page.locator("#emotion-switch-state")).to_have_text("")


def robot_dot(page: Page) -> tuple[float, float]:
    where = page.locator("#map").get_attribute("data-robot")
    assert where, "the robot is not drawn on the map"
    x, y = where.split(",")
    return float(x), float(y)


def test_robot_moves_on_the_map(page: Page, sim: str) -> None:
    expect(page.locator("#map-message")).to_be_hidden()
    expect(page.locator("#map-caption")).to_contain_text("places")
    expect(page.locator("#map")).to_have_attribute("data-robot", re.compile(r"\d"))
    info = page.request.get(sim + "/api/map").json()
    assert any(place["name"] == "cafeteria" for place in info["locations"])
    go_idle(page, sim)
    start = robot_dot(page)
    page.fill("#chat-input", "Go to the cafeteria")
    page.press("#chat-input", "Enter")
    expect(page.locator("#map-pose")).to_contain_text("m to go")  # a route is planned and drawn
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline:
        now = robot_dot(page)
        if abs(now[0] - start[0]) + abs(now[1] - start[1]) > 5:
            break
        page.wait_for_timeout(200)
    assert abs(now[0] - start[0]) + abs(now[1] - start[1]) > 5, f"the dot stayed at {start}"
    page.screenshot(path=str(SHOTS / "cyborg-dashboard-map.png"))


def test_page_reconnects_when_the_robot_restarts(browser: Browser, tmp_path: Path) -> None:
    first = Sim(tmp_path / "first")
    page = open_page(browser, first.url + "/", [])  # errors expected: the robot goes away for a while
    try:
        expect(page.locator("#conn")).to_have_attribute("data-state", "open")
        first.stop()
        expect(page.locator("#conn")).to_have_attribute("data-state", "closed")
        expect(page.locator("#conn-text")).to_contain_text("reconnecting")
        second = Sim(tmp_path / "second", port=first.port)
        try:
            expect(page.locator("#conn")).to_have_attribute("data-state", "open")
            expect(page.locator("#top-state")).not_to_have_text(NOTHING)
            page.wait_for_function("() => document.querySelector('#graph .node.active') !== null")
        finally:
            second.stop()
    finally:
        page.context.close()
        first.stop()


def test_without_a_base_the_map_panel_says_so(browser: Browser, tmp_path: Path) -> None:
    yaml = packaged_config("cyborg.yaml").read_text()
    assert "rosarnl_node: {kind: simulated_base}" in yaml
    config = tmp_path / "no-base.yaml"
    config.write_text(yaml.replace("rosarnl_node: {kind: simulated_base}", ""))
    robot = Sim(tmp_path / "data", config=config)
    errors: list[str] = []
    page = open_page(browser, robot.url + "/", errors)
    try:
        expect(page.locator("#conn")).to_have_attribute("data-state", "open")
        expect(page.locator("#map-message")).to_be_visible()
        expect(page.locator("#map-message")).to_contain_text("This robot has no simulated base")
        expect(page.locator("#map-message")).to_contain_text("rosarnl_node: {kind: simulated_base}")
        expect(page.locator("#map-caption")).to_have_text("no simulated base")
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-no-base.png"))
    finally:
        page.context.close()
        robot.stop()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)
