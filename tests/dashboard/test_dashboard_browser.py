"""The dashboard in a real headless Chromium against `cyborg sim` (the default Cyborg), as a user sees it.

One robot (virtual time at a few times real speed) and one browser serve all tests
here; each test opens its own page and fails on any console error. Screenshots
go to /tmp/cyborg-dashboard-*.png. Needs the `playwright` package (dev extras)
and the system Chromium (`scripts/install-system-deps --test`); no browser is
downloaded.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import (
    Browser,
    ConsoleMessage,
    Locator,
    Page,
    Route,
    WebSocketRoute,
    expect,
    sync_playwright,
)

from cyborg.app.config import packaged_config
from tests.support.paths import GLASSGARDEN

pytestmark = pytest.mark.browser

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
CYBORG = [sys.executable, "-m", "cyborg.cli"]
NOTHING = "\u2013"  # what the page shows before it knows a value
START_GUARD = 180
"""Real seconds a robot may take to print its address while its process runs: a guard against a
hang, not a speed test (at load 40 a start took over 20 s, and the tests failed in setup)."""


class Sim:
    """One `cyborg sim` process with the packaged Cyborg; its output goes to a file (never blocks)."""

    def __init__(
        self, data: Path, port: int = 0, config: Path | None = None, occupancy_map: Path | None = None
    ) -> None:
        data.mkdir(parents=True, exist_ok=True)
        self.output = data / "sim.log"
        chosen = ["--config", str(config)] if config else []
        chosen += ["--map", str(occupancy_map)] if occupancy_map else []
        with self.output.open("w") as out:
            self.process = subprocess.Popen(
                [*CYBORG, "sim", "--port", str(port), "--db", str(data), "--speed", SPEED, *chosen],
                stdout=out,
                stderr=subprocess.STDOUT,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
        deadline = time.monotonic() + START_GUARD
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


def open_page(
    browser: Browser,
    url: str,
    errors: list[str],
    size: tuple[int, int] = (1400, 900),
    before: Callable[[Page], object] | None = None,
) -> Page:
    """A page (1400x900 unless told) on ``url`` that appends its console errors to ``errors``;
    ``before`` may route requests before the page loads."""
    tab = browser.new_context(viewport={"width": size[0], "height": size[1]}).new_page()
    tab.set_default_timeout(15_000)
    if before is not None:
        before(tab)

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
    expect(page.locator("#top-graph")).to_have_text("in this process (no ROS graph)")  # which graph
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
    expect(page.locator('#emotion-select option[value="elated"]')).to_have_text("elated (happy)")
    page.select_option("#emotion-select", "elated")
    page.click("#emotion-set")
    expect(page.locator("#emotion-name")).to_have_text("elated (happy)")  # table 2.2's name and bracket
    expect(page.locator("#top-emotion")).to_have_text("elated (happy)")
    expect(page.locator("#val-p")).to_have_text("+0.50")
    page.request.post(sim + "/api/emotion/set", data={"name": "surprised"})  # a typed alias
    expect(page.locator("#emotion-name")).to_have_text("puzzled (surprised)")
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


def test_a_mark_then_a_look_back_at_it_then_live_again(page: Page, sim: str) -> None:
    """The mark button puts a note into the recording; the look back (the last minutes, from the
    recording) lists it, jumps to it, draws the map behind the track; "back to live" returns."""
    expect(page.locator("#recorder-state")).to_have_text("on")
    page.fill("#mark-note", "odd turn here")
    page.click("#mark")
    expect(page.locator("#control-message")).to_contain_text("marked: odd turn here")
    page.click("#lookback")
    page.wait_for_selector("body[data-shown]")
    expect(page.locator("#title")).to_have_text("Cyborg: looking back")
    mark = page.locator("#marks button", has_text="odd turn here")
    expect(mark).to_be_visible()
    expect(page.locator("body")).to_have_attribute("data-map", "drawn")
    mark.click()
    marked_at = float((mark.inner_text()).split(" s:")[0])
    page.wait_for_function(f"Math.abs(Number(document.body.dataset.shown) - {marked_at}) < 0.2")
    assert page.inner_text("#state") not in ("", NOTHING), "the state at the mark is shown"
    page.screenshot(path=str(SHOTS / "cyborg-dashboard-lookback.png"))
    page.click("#live")
    expect(page.locator("#conn")).to_have_attribute("data-state", "open")


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
    expect(page.locator("#log")).to_contain_text("Shall I go to the cafeteria?")  # 7.7: it asks first
    page.fill("#chat-input", "yes")
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


def test_a_parallel_state_shows_one_lane_per_region_and_both_states_in_control(
    browser: Browser, tmp_path: Path
) -> None:
    robot = Sim(tmp_path / "data", config=packaged_config("monitor.yaml"))
    errors: list[str] = []
    page = open_page(browser, robot.url + "/", errors)
    try:
        lanes = page.locator("#health-regions .lane")
        expect(lanes).to_have_count(2)
        expect(lanes.nth(0)).to_contain_text("monitor (priority 10)")
        expect(lanes.nth(0)).to_contain_text("battery_ok")
        expect(lanes.nth(1)).to_contain_text("behaviour (priority 1)")
        expect(page.locator('[id="state:battery_ok"]')).to_have_class(re.compile(r"\bactive\b"))
        expect(page.locator('[id="state:idle"]')).to_have_class(re.compile(r"\bactive\b"))
        expect(page.locator("#health-stats")).to_contain_text("mutes")
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-parallel.png"))
    finally:
        page.context.close()
        robot.stop()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


SMALL = (1280, 800)  # the smallest window the layout is made for
Box = Mapping[str, Any]  # a bounding box (x, y, width, height), a place label's with its name


def box_of(page: Page, selector: str) -> Box:
    found = page.locator(selector).first.bounding_box()
    assert found is not None, f"{selector} is not shown"
    return found


def inside(inner: Box, outer: Box, slack: float = 1.0) -> bool:
    return bool(
        inner["x"] >= outer["x"] - slack
        and inner["y"] >= outer["y"] - slack
        and inner["x"] + inner["width"] <= outer["x"] + outer["width"] + slack
        and inner["y"] + inner["height"] <= outer["y"] + outer["height"] + slack
    )


def test_the_emotion_shown_survives_state_changes(page: Page, sim: str) -> None:
    """The emotion name and bars follow the emotion records, not the status the page loaded with."""
    page.request.post(sim + "/api/emotion/switch", data={"on": False})  # no decay or feedback meanwhile
    try:
        loaded_with = page.locator("#emotion-name").inner_text()
        wanted = "inhibited" if not loaded_with.startswith("inhibited") else "angry"
        emotions = page.request.get(sim + "/api/emotions").json()
        pleasure = emotions["prototypes"][wanted][0]
        aliases = sorted(alias for alias, name in emotions["aliases"].items() if name == wanted)
        shown = f"{wanted} ({', '.join(aliases)})" if aliases else wanted
        page.select_option("#emotion-select", wanted)
        page.click("#emotion-set")
        expect(page.locator("#emotion-name")).to_have_text(shown)
        go_idle(page, sim)
        page.locator('#event-buttons button[data-event="music_play"]').click()
        expect(page.locator("#top-state")).to_have_text("music")
        page.wait_for_timeout(1500)  # the status and health polls that follow a state change
        expect(page.locator("#emotion-name")).to_have_text(shown)
        expect(page.locator("#top-emotion")).to_have_text(shown)
        expect(page.locator("#val-p")).to_have_text(f"{pleasure:+.2f}")
        go_idle(page, sim)
        page.wait_for_timeout(500)
        expect(page.locator("#emotion-name")).to_have_text(shown)
    finally:
        page.request.post(sim + "/api/emotion/switch", data={"on": True})


class FakeSocket:
    """Stands in for the robot's websocket: says hello, then sends whatever records the test gives."""

    def __init__(self, page: Page) -> None:
        self.route: WebSocketRoute | None = None
        page.route_web_socket(re.compile(r".*/api/ws$"), self._connect)

    def _connect(self, route: WebSocketRoute) -> None:
        self.route = route
        route.send(json.dumps({"type": "hello", "status": {"state": "idle", "emotion": "neutral"}}))

    def send(self, page: Page, record: dict[str, Any]) -> None:
        page.wait_for_function("() => !window.cyborgDashboard.syncing")
        assert self.route is not None
        self.route.send(json.dumps(record))


def test_motivator_decisions_show_reward_cost_and_the_choice(browser: Browser, sim: str) -> None:
    errors: list[str] = []
    socket: list[FakeSocket] = []
    page = open_page(browser, sim + "/", errors, before=lambda tab: socket.append(FakeSocket(tab)))
    try:
        fake = socket[0]
        page.locator('.log-filters input[data-type="nothing"]').check()  # hidden unless asked for
        seq = 10**6
        # Ranked by reward among those whose reward exceeds their cost: "music_play" wins on reward
        # although "joke_tell" has the larger net; "weather_tell" costs more than it brings.
        candidates = [
            {"event": "joke_tell", "reward": 0.3, "cost": 0.1, "net": 0.2, "eligible": True},
            {"event": "music_play", "reward": 0.5, "cost": 0.45, "net": 0.05, "eligible": True},
            {"event": "weather_tell", "reward": 0.05, "cost": 0.2, "net": -0.15, "eligible": False},
        ]
        fake.send(
            page,
            {
                "seq": seq,
                "t": 50.0,
                "type": "motivator",
                "event": "music_play",
                "candidates": candidates,
                "reason": "music_play: reward 0.5000, cost 0.4500: reward > cost",
                "rule": "reward",
            },
        )
        row = page.locator(f'#log li[data-seq="{seq}"]')
        expect(row.locator(".line")).to_have_text("chose music_play")
        expect(row.locator(".rule")).to_contain_text("by reward")
        chips = row.locator(".cand")
        expect(chips).to_have_count(3)
        chosen = row.locator(".cand.chosen")
        expect(chosen).to_have_count(1)
        expect(chosen).to_have_text("✓ music_play reward 0.5000 · cost 0.4500 · net 0.0500")
        assert chips.first.get_attribute("data-event") == "music_play", "the chosen one comes first"
        expect(row.locator('.cand[data-event="joke_tell"]')).to_have_text(
            "joke_tell reward 0.3000 · cost 0.1000 · net 0.2000"
        )
        refused = row.locator('.cand[data-event="weather_tell"]')
        expect(refused).to_have_class(re.compile(r"\bineligible\b"))
        expect(refused).to_have_text("✗ weather_tell reward 0.0500 · cost 0.2000 · net -0.1500")
        expect(refused).to_have_attribute(
            "title", re.compile("not eligible: its cost is not below its reward")
        )

        # Nothing chosen, with or without candidates, even in odd shapes: one line saying why.
        for n, t in enumerate((52.0, 54.0, 56.0), start=1):
            fake.send(
                page,
                {
                    "seq": seq + n,
                    "t": t,
                    "type": "motivator",
                    "event": None,
                    "candidates": [],
                    "reason": f"{t - 50:.1f} s of 10 s in state 'lobby': waiting before choosing",
                },
            )
        # (the page's history holds the live robot's own decisions too: count only these)
        waiting = page.locator('#log li[data-type="motivator"][data-chosen="no"]').filter(
            has_text="in state 'lobby': waiting"
        )
        expect(waiting).to_have_count(1)  # three alike: one row that counts them
        expect(waiting.locator(".line")).to_have_text(
            "nothing chosen: 6.0 s of 10 s in state 'lobby': waiting before choosing"
        )
        expect(waiting.locator(".repeats")).to_have_text("\u00d73")
        fake.send(page, {"seq": seq + 4, "t": 58.0, "type": "motivator", "event": None, "reason": ""})
        fake.send(
            page,
            {
                "seq": seq + 5,
                "t": 60.0,
                "type": "motivator",
                "event": None,
                "candidates": [candidates[2]],
                "reason": "all candidates' reward <= cost in state 'lobby'",
            },
        )
        lines = page.locator('#log li[data-type="motivator"] .line').all_inner_texts()
        assert lines[:3] == [
            "nothing chosen: all candidates' reward <= cost in state 'lobby'",
            "nothing chosen: no reason given",
            "nothing chosen: 6.0 s of 10 s in state 'lobby': waiting before choosing",
        ], lines
        rule = page.request.get(sim + "/api/health").json()["motivator"]["selection"]
        latest = page.locator(f'#log li[data-seq="{seq + 5}"]')
        expect(latest.locator(".rule")).to_contain_text(f"by {rule}")  # no rule in the record: the config's
        expect(latest.locator(".cand.ineligible")).to_contain_text("weather_tell")
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-motivator.png"))
    finally:
        page.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def test_health_shows_feedback_age_and_an_unknown_emotion_switch(browser: Browser, sim: str) -> None:
    """Fields the robot may send: a module's last feedback (else its last activity) and a switch it cannot see."""

    def add_fields(route: Route) -> None:
        health = route.fetch().json()
        for module in health["modules"]:
            if module["name"] == "cyborg_joke":
                module["last_feedback_at"] = health["time"] - 42.0
                module["seconds_since_feedback"] = 42.0
        health["emotion_enabled"] = None  # as `cyborg node cyborg_api` says before any on/off
        route.fulfill(json=health)

    errors: list[str] = []
    page = open_page(browser, sim + "/", errors, before=lambda tab: tab.route("**/api/health", add_fields))
    try:
        joke = page.locator('#health-table tr[data-module="cyborg_joke"] td').last
        expect(joke).to_have_text("42 s ago")
        header = page.locator("#health-table thead th").filter(has_text="last")
        expect(header).to_have_count(1)
        expect(header).to_be_visible()
        expect(header).to_have_text("last feedback")
        expect(page.locator('#health-table tr[data-module="cyborg_weather"] td').last).to_have_text("never")
        expect(page.locator("#emotion-switch-state")).to_have_text("on/off not known yet")
        assert page.locator("#emotion-switch").evaluate("box => box.indeterminate")
    finally:
        page.unroute_all(behavior="ignoreErrors")  # a poll in flight must not fail the next test
        page.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def test_a_robot_that_cannot_save_says_so_and_says_when_it_saves_again(browser: Browser, sim: str) -> None:
    """Issue 12, item 4: /api/health and an emotion command's answer as a robot on a full disk sends
    them (tests/interfaces/test_full_disk.py has them from one); the rest is the real robot."""
    disk = {"full": True}
    problem = "could not save the PAD values in /data/controller.db: database or disk is full"
    fix = "free some space on that disk (or give another folder with --data-dir)"

    def health(route: Route) -> None:
        answer = route.fetch().json()
        assert answer["storage"]["saved"] is True  # the real robot saves
        if disk["full"]:
            answer["storage"].update(
                saved=False, problem=problem, fix=fix, failed_writes=7, unsaved=["the PAD values"]
            )
        route.fulfill(json=answer)

    def emotion_set(route: Route) -> None:
        answer = route.fetch().json()
        if disk["full"]:
            answer.update(
                saved=False,
                warning=f"the robot is not saving its data ({problem}; fix: {fix}): it makes this change "
                "in memory only, and saves it once writes work again",
            )
        route.fulfill(json=answer)

    def intercept(tab: Page) -> None:
        tab.route("**/api/health", health)
        tab.route("**/api/emotion/set", emotion_set)

    errors: list[str] = []
    page = open_page(browser, sim + "/", errors, before=intercept)
    try:
        warning = page.locator("#storage-warning")
        expect(warning).to_be_visible()
        expect(warning).to_contain_text("not saved")
        expect(page.locator("#storage-reason")).to_have_text("database or disk is full")
        expect(warning).to_have_attribute("title", re.compile(f"goes on in memory.*Fix: {re.escape(fix)}"))
        page.select_option("#emotion-select", "bored")
        page.click("#emotion-set")
        message = page.locator("#control-message")
        expect(message).to_contain_text("emotion set to bored, but the robot is not saving its data")
        expect(message).to_have_class(re.compile("error"))
        expect(page.locator("#emotion-name")).to_have_text(re.compile("^bored"))  # made, in memory
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-not-saved.png"))

        disk["full"] = False
        expect(warning).to_be_hidden()
        expect(message).to_contain_text("saving again: the robot's data is written to")
    finally:
        page.unroute_all(behavior="ignoreErrors")  # a poll in flight must not fail the next test
        page.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def test_layout_at_1280x800_shows_every_module_and_a_readable_log(browser: Browser, sim: str) -> None:
    errors: list[str] = []
    page = open_page(browser, sim + "/", errors, size=SMALL)
    try:
        expect(page.locator("#conn")).to_have_attribute("data-state", "open")
        assert page.evaluate("() => document.documentElement.scrollHeight") <= SMALL[1], (
            "the page does not scroll"
        )
        header_cut = page.evaluate(
            """() => [...document.querySelectorAll('header.topbar > *')]
                .filter(e => e.offsetParent !== null && e.getBoundingClientRect().right > window.innerWidth)
                .map(e => e.id || e.textContent.trim())"""
        )
        assert not header_cut, f"header items past the window's right edge: {header_cut}"
        for _ in range(6):  # short state records to fill the log
            go_idle(page, sim)
            page.request.post(sim + "/api/event", data={"name": "music_play"})
            expect(page.locator("#top-state")).to_have_text("music")
        go_idle(page, sim)
        # One-line records only: a motivator decision (three lines with its candidates) arrives
        # every 2 s, so how many rows fit would depend on how long the shared sim has run.
        page.locator('input[type="checkbox"][data-type="motivator"]').uncheck()
        page.wait_for_timeout(1200)

        # Measured in one go: the page redraws the table every second and the log with each record.
        seen = page.evaluate(
            """() => {
              const within = (el, box) => { const r = el.getBoundingClientRect();
                return r.top >= box.top - 1 && r.bottom <= box.bottom + 1 && r.left >= box.left - 1 && r.right <= box.right + 1; };
              const table = document.querySelector('#panel-health .scroll').getBoundingClientRect();
              const log = document.getElementById('log').getBoundingClientRect();
              const rows = [...document.querySelectorAll('#health-table tbody tr')];
              return {
                modules: rows.map(r => r.dataset.module),
                outOfView: rows.filter(r => !within(r, table)).map(r => r.dataset.module),
                cut: [...document.querySelectorAll('#health-table td')]
                  .filter(c => c.scrollWidth > c.clientWidth + 1).map(c => c.textContent),
                logRows: [...document.querySelectorAll('#log li')].filter(r => within(r, log)).length,
              };
            }"""
        )
        modules = page.request.get(sim + "/api/health").json()["modules"]
        assert sorted(seen["modules"]) == sorted(m["name"] for m in modules)
        assert not seen["outOfView"], f"module rows not in view: {seen['outOfView']}"
        assert not seen["cut"], f"cut cells: {seen['cut']}"
        assert seen["logRows"] >= 10, f"only {seen['logRows']} log rows in view"

        figure = box_of(page, "#panel-emotion .emotion-plots figure")
        for item in page.locator("#pad-legend span").all():
            legend = item.bounding_box()
            assert legend is not None and inside(legend, figure), f"the legend's {item.inner_text()} is cut"
        space = page.evaluate("() => window.cyborgDashboard.spaceLabels")
        assert len(space["labels"]) == 10
        for label in space["labels"]:
            assert label["x"] >= 0 and label["x"] + label["w"] <= space["width"], f"{label['name']} is cut"
            assert label["y"] >= 0 and label["y"] + label["h"] <= space["height"], f"{label['name']} is cut"
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-1280x800.png"))
    finally:
        page.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def drawing_size(page: Page) -> list[float]:
    """The state machine drawing's size in its own units (it grows as a superstate opens)."""
    size: list[float] = page.locator("#graph svg .graph").first.evaluate(
        "g => { const b = g.getBBox(); return [b.width, b.height]; }"
    )
    return size


def label_height(page: Page, state: str) -> float:
    return float(box_of(page, f'[id="state:{state}"] text')["height"])


def test_state_machine_zooms_to_readable_labels(browser: Browser, sim: str) -> None:
    errors: list[str] = []
    page = open_page(browser, sim + "/", errors, size=SMALL)
    try:
        expect(page.locator("#graph svg")).to_be_visible()
        go_idle(page, sim)
        graph = box_of(page, "#graph")
        assert label_height(page, "idle") >= 10, "fitted to the panel, the names read (issue 16)"
        assert inside(box_of(page, "#graph svg .graph"), graph), "at first the whole machine is in view"

        for _ in range(3):  # again if the drawing changed meanwhile (the robot entered a superstate)
            page.click('#graph-tools button[data-zoom="fit"]')
            page.wait_for_timeout(200)
            drawn = drawing_size(page)
            before = box_of(page, '[id="state:idle"]')["width"]
            page.click('#graph-tools button[data-zoom="in"]')
            page.wait_for_timeout(200)
            zoomed = box_of(page, '[id="state:idle"]')["width"]
            if drawing_size(page) == drawn:
                break
        assert zoomed == pytest.approx(before * 1.5, rel=0.02), "+ zooms in"
        page.mouse.move(graph["x"] + graph["width"] / 2, graph["y"] + graph["height"] / 2)
        page.mouse.wheel(0, 400)
        page.wait_for_timeout(300)
        assert box_of(page, '[id="state:idle"]')["width"] < zoomed * 0.95, "the wheel zooms out"
        page.click('#graph-tools button[data-zoom="fit"]')
        page.wait_for_timeout(200)
        # The robot wanders meanwhile, and a superstate it enters opens, so the drawing's size may
        # have changed since it was first fitted: "fit" means the whole of it fills the panel.
        drawing, panel = box_of(page, "#graph svg .graph"), box_of(page, "#graph svg")
        assert inside(drawing, panel), "fit brings the whole machine back in view"
        filled = max(drawing["width"] / panel["width"], drawing["height"] / panel["height"])
        assert filled == pytest.approx(1.0, abs=0.03), "and fills the panel"

        # Follow: the active state in view, labels big enough to read, as it changes.
        page.check("#graph-follow")
        page.wait_for_timeout(300)
        assert label_height(page, "idle") >= 12, "follow zooms in to a readable size"
        assert inside(box_of(page, '[id="state:idle"]'), graph)
        page.locator('#event-buttons button[data-event="conversation_interest"]').click()
        expect(page.locator("#top-state")).to_have_text("conversation")
        page.wait_for_timeout(400)
        assert inside(box_of(page, '[id="state:conversation"]'), graph), "follow keeps the new state in view"
        assert label_height(page, "conversation") >= 12
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-graph-follow.png"))
        go_idle(page, sim)
    finally:
        page.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def visible_place_labels(page: Page) -> list[Box]:
    boxes: list[Box] = page.locator("#map .place-label").evaluate_all(
        """labels => labels.filter(l => l.getAttribute('visibility') !== 'hidden').map(l => {
             const r = l.getBoundingClientRect();
             return {name: l.parentNode.dataset.name, x: r.x, y: r.y, width: r.width, height: r.height};
           })"""
    )
    return boxes


def overlapping(boxes: list[Box]) -> list[tuple[Any, Any]]:
    return [
        (a["name"], b["name"])
        for i, a in enumerate(boxes)
        for b in boxes[i + 1 :]
        if a["x"] < b["x"] + b["width"] - 0.5
        and b["x"] < a["x"] + a["width"] - 0.5
        and a["y"] < b["y"] + b["height"] - 0.5
        and b["y"] < a["y"] + a["height"] - 0.5
    ]


def test_a_crowded_map_keeps_names_apart_and_zooms(browser: Browser, tmp_path: Path) -> None:
    assert GLASSGARDEN.is_file(), f"{GLASSGARDEN} is missing (the shared folder beside the repository)"
    robot = Sim(tmp_path / "data", occupancy_map=GLASSGARDEN)
    errors: list[str] = []
    page = open_page(browser, robot.url + "/", errors, size=SMALL)
    try:
        expect(page.locator("#map-caption")).to_contain_text("21 places")
        expect(page.locator("#map .place")).to_have_count(21)
        area = box_of(page, "#map")
        page.wait_for_timeout(500)
        fitted = visible_place_labels(page)
        assert fitted and not overlapping(fitted), f"names cover each other: {overlapping(fitted)}"
        assert all(inside(label, area) for label in fitted), "a name sticks out of the map"
        hidden = int(page.locator("#map").get_attribute("data-hidden-labels") or "0")
        assert hidden > 0 and len(fitted) + hidden == 21
        expect(page.locator("#map-hint")).to_have_text(re.compile(rf"^{hidden} names? hidden, zoom in$"))
        text_size = page.locator("#map .place-label text").first.evaluate(
            "t => parseFloat(getComputedStyle(t).fontSize)"
        )
        assert text_size >= 11

        for _ in range(3):
            page.click('#map-tools button[data-zoom="in"]')
        page.wait_for_timeout(300)
        zoomed = visible_place_labels(page)
        assert not overlapping(zoomed)
        assert int(page.locator("#map").get_attribute("data-hidden-labels") or "0") < hidden, (
            "zoomed in, more of the places in view have their names"
        )
        before = robot_dot(page)
        page.mouse.move(area["x"] + area["width"] / 2, area["y"] + area["height"] / 2)
        page.mouse.down()
        page.mouse.move(area["x"] + area["width"] / 2 + 60, area["y"] + area["height"] / 2 + 40, steps=5)
        page.mouse.up()
        page.wait_for_timeout(300)
        after = robot_dot(page)
        assert after[0] - before[0] == pytest.approx(60, abs=8) and after[1] - before[1] == pytest.approx(
            40, abs=8
        ), f"dragging pans the map: the robot went from {before} to {after}"
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-glassgarden.png"))
    finally:
        page.context.close()
        robot.stop()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def test_heard_sentences_show_their_confidence_and_rejected_ones_are_greyed(
    browser: Browser, sim: str
) -> None:
    errors: list[str] = []
    socket: list[FakeSocket] = []
    page = open_page(browser, sim + "/", errors, before=lambda tab: socket.append(FakeSocket(tab)))
    try:
        fake = socket[0]
        seq = 2 * 10**6
        base = {"type": "recognised", "raw": ""}
        fake.send(
            page,
            {
                **base,
                "seq": seq,
                "t": 60.0,
                "text": "where is the cafeteria",
                "confidence": 0.42,
                "accepted": True,
            },
        )
        fake.send(
            page,
            {
                **base,
                "seq": seq + 1,
                "t": 61.0,
                "text": "where is the like",
                "confidence": 0.0,
                "accepted": False,
            },
        )
        believed, rejected = (
            page.locator(f'#log li[data-seq="{seq}"]'),
            page.locator(f'#log li[data-seq="{seq + 1}"]'),
        )
        expect(believed).to_contain_text("“where is the cafeteria” 42 %")
        expect(rejected).to_contain_text("“where is the like” 0 % (rejected)")

        def opacity(row: Locator) -> float:
            return float(row.evaluate("e => getComputedStyle(e).opacity"))

        assert opacity(believed) == 1.0 and opacity(rejected) < 0.6, "a rejected sentence is greyed"
        page.locator('.log-filters input[data-type="recognised"]').uncheck()
        expect(believed).to_be_hidden()
    finally:
        page.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)
