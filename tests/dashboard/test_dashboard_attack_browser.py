"""Issue 12, item 1 in a real Chromium: a page of another origin tries to command the robot and
listen in, a DNS-rebinding page tries to be the robot's own, and the real dashboard still works,
on loopback and, with its token, beyond it. Screenshots go to /tmp/cyborg-attack-*.png.

The attacker's page is served from a second local origin (another port of 127.0.0.1), as a page
of any web site the operator has open would reach the robot."""

from __future__ import annotations

import json
import os
import re
import subprocess
import threading
import time
import urllib.request
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Browser, expect

from tests.dashboard.test_dashboard_browser import (  # the dashboard tests' robot, browser and page helpers
    CHROMIUM,
    CHROMIUM_ARGS,
    CYBORG,
    SHOTS,
    START_GUARD,
    Sim,
    browser,  # noqa: F401  (a fixture)
    open_page,
)

pytestmark = pytest.mark.browser

ATTACK = """<!doctype html>
<html><head><title>Free cat pictures</title></head><body>
<h1>Free cat pictures</h1>
<form id="form" method="POST" enctype="text/plain" target="sink" action="ROBOT/api/say">
  <input name='{"text": "take me to the cafeteria", "x": "' value='"}'>
</form>
<iframe name="sink" id="sink"></iframe>
<pre id="log"></pre>
<script>
const robot = "ROBOT";
const results = (window.results = { wsMessages: 0 });
const note = (key, value) => { results[key] = value; document.getElementById("log").textContent = JSON.stringify(results, null, 1); };
async function attack() {
  // No preflight: a text/plain body the old API read as JSON.
  await fetch(robot + "/api/emotion/switch", { method: "POST", mode: "no-cors",
    headers: { "Content-Type": "text/plain" }, body: JSON.stringify({ on: false }) }).catch((e) => note("switchError", String(e)));
  await fetch(robot + "/api/say", { method: "POST", mode: "no-cors",
    headers: { "Content-Type": "text/plain" }, body: JSON.stringify({ text: "take me to the cafeteria" }) }).catch(() => {});
  try {
    const reply = await fetch(robot + "/api/status");
    note("statusRead", await reply.text());
  } catch (e) { note("statusError", String(e)); }
  await new Promise((resolve) => {  // the speech stream
    const socket = new WebSocket(robot.replace("http", "ws") + "/api/ws");
    socket.onopen = () => note("wsOpened", true);
    socket.onmessage = () => note("wsMessages", results.wsMessages + 1);
    socket.onclose = (event) => { note("wsClosed", event.code); resolve(); };
    setTimeout(resolve, 3000);
  });
  document.getElementById("sink").onload = () => note("formDone", true);
  document.getElementById("form").submit();  // an HTML form: no preflight either
}
attack().finally(() => note("fetchesDone", true));
</script></body></html>
"""


class AttackerSite:
    """http://127.0.0.1:OTHER/ serving the attack page: another origin on the same machine."""

    def __init__(self, robot: str) -> None:
        page = ATTACK.replace("ROBOT", robot).encode()

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                self.send_response(200)
                self.send_header("Content-Type", "text/html")
                self.send_header("Content-Length", str(len(page)))
                self.end_headers()
                self.wfile.write(page)

            def log_message(self, format: str, *args: Any) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/"
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


def get(url: str, token: str | None = None) -> Any:
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    with urllib.request.urlopen(urllib.request.Request(url, headers=headers), timeout=10) as response:
        return json.loads(response.read())


@pytest.fixture
def robot(tmp_path: Path) -> Iterator[Sim]:
    sim = Sim(tmp_path / "data")
    try:
        yield sim
    finally:
        sim.stop()


def test_a_page_of_another_origin_can_neither_command_nor_overhear_the_robot(
    browser: Browser,  # noqa: F811
    robot: Sim,
) -> None:
    site = AttackerSite(robot.url)
    try:
        attacker = browser.new_context().new_page()
        attacker.goto(site.url)
        attacker.wait_for_function(
            "() => window.results.fetchesDone && window.results.formDone", timeout=20_000
        )
        results = attacker.evaluate("() => window.results")
        attacker.screenshot(path=str(SHOTS / "cyborg-attack-page.png"))
        attacker.context.close()
    finally:
        site.close()
    heard = [r["text"] for r in get(robot.url + "/api/records?type=heard")]
    assert not any("cafeteria" in text for text in heard), f"the robot heard the attacker: {heard}"
    assert get(robot.url + "/api/health")["emotion_enabled"] is True, "the attacker switched emotions off"
    assert not results.get("wsOpened") and results["wsMessages"] == 0, f"the attacker listened in: {results}"
    assert "statusRead" not in results, "the attacker read the robot's status"

    errors: list[str] = []
    page = open_page(browser, robot.url + "/", errors)  # the real dashboard, after the attack
    expect(page.locator("#conn")).to_have_attribute("data-state", "open")
    expect(page.locator("#graph svg")).to_be_visible()
    page.fill("#chat-input", "hello")
    page.press("#chat-input", "Enter")
    expect(page.locator("#control-message")).to_have_text("heard: hello")
    expect(page.locator('#log li[data-type="heard"] .text').first).to_contain_text("hello")
    page.locator("#emotion-switch").uncheck()
    expect(page.locator("#emotion-switch-state")).to_have_text("switched off")
    page.locator("#emotion-switch").check()
    expect(page.locator("#emotion-switch-state")).to_have_text("")
    page.screenshot(path=str(SHOTS / "cyborg-attack-dashboard-after.png"))
    page.context.close()
    assert not errors, "the dashboard logged errors:\n" + "\n".join(errors)


def test_a_dns_rebinding_page_is_not_served(browser: Browser, robot: Sim) -> None:  # noqa: F811
    """attacker.example resolves to this machine, so the page and the robot share an origin;
    the Host header still names the attacker, and the robot refuses it."""
    rule = "MAP attacker.example 127.0.0.1"  # what the attacker's DNS answers after the first visit
    chromium = browser.browser_type.launch(
        executable_path=CHROMIUM, args=[*CHROMIUM_ARGS, f"--host-resolver-rules={rule}"]
    )
    try:
        page = chromium.new_page()
        response = page.goto(f"http://attacker.example:{robot.port}/")
        assert response is not None and response.status == 403
        expect(page.locator("body")).to_contain_text("is not this robot's address")
        status = page.evaluate("() => fetch('/api/status').then((r) => r.status)")
        assert status == 403
        page.screenshot(path=str(SHOTS / "cyborg-attack-rebinding.png"))
    finally:
        chromium.close()
    assert get(robot.url + "/api/status")["state"], "the robot itself answers on its own address"


ADDRESS = re.compile(r"dashboard and API: (http://127\.0\.0\.1:(\d+))/#token=(\S+)")


@pytest.fixture
def networked_robot(tmp_path: Path) -> Iterator[tuple[str, str, str]]:
    """`cyborg sim --host 0.0.0.0`: (base URL, token, its output so far)."""
    log = tmp_path / "sim.log"
    with log.open("w") as out:
        process = subprocess.Popen(
            [
                *CYBORG,
                "sim",
                "--host",
                "0.0.0.0",
                "--port",
                "0",
                "--db",
                str(tmp_path / "data"),
                "--speed",
                "2",
            ],
            stdout=out,
            stderr=subprocess.STDOUT,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
    try:
        deadline = time.monotonic() + START_GUARD
        match = None
        while match is None and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.05)
            match = ADDRESS.search(log.read_text())
        assert match is not None, "no address with a token printed:\n" + log.read_text()
        yield match.group(1), match.group(3), log.read_text()
    finally:
        process.terminate()
        process.wait(timeout=20)


def test_beyond_loopback_the_dashboard_works_with_the_printed_address_only(
    browser: Browser,  # noqa: F811
    networked_robot: tuple[str, str, str],
) -> None:
    url, token, output = networked_robot
    assert "warning: serving on 0.0.0.0" in output

    errors: list[str] = []
    page = open_page(browser, f"{url}/#token={token}", errors)  # as printed at start
    expect(page.locator("#conn")).to_have_attribute("data-state", "open")
    expect(page.locator("#graph svg")).to_be_visible()
    assert "token" not in page.url, "the token is taken out of the address bar"
    page.fill("#chat-input", "hello")
    page.press("#chat-input", "Enter")
    expect(page.locator("#control-message")).to_have_text("heard: hello")
    page.reload()  # the tab keeps the token
    expect(page.locator("#conn")).to_have_attribute("data-state", "open")
    page.screenshot(path=str(SHOTS / "cyborg-attack-token-dashboard.png"))
    page.context.close()
    assert not errors, "the dashboard logged errors:\n" + "\n".join(errors)

    bare = browser.new_context().new_page()  # the address without the token
    bare.goto(url + "/")
    expect(bare.locator("#control-message")).to_contain_text("needs its token")
    expect(bare.locator("#conn")).not_to_have_attribute("data-state", "open")
    bare.screenshot(path=str(SHOTS / "cyborg-attack-no-token.png"))
    bare.context.close()
    assert get(url + "/api/status", token)[
        "state"
    ]  # the command tool: tests/interfaces/test_sim_hardening.py
