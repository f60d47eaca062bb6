"""The command tool against a running `cyborg sim`, as a user drives it from a terminal."""

from __future__ import annotations

import json
import os
import re
import subprocess
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from cyborg.app.config import packaged_config
from tests.support.tools import CYBORG, tool


@pytest.fixture
def running_sim(tmp_path: Path) -> Iterator[str]:
    yield from start_sim("demo.yaml", tmp_path)


@pytest.fixture
def running_cyborg(tmp_path: Path) -> Iterator[str]:
    """The default robot (with its speech gatekeeper), ten times faster than real time."""
    yield from start_sim("cyborg.yaml", tmp_path, "--speed", "10")


def start_sim(config: str, data: Path, *extra: str) -> Iterator[str]:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    process = subprocess.Popen(
        [*CYBORG, "sim", "--config", str(packaged_config(config)), "--port", "0", "--db", str(data), *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
    )
    assert process.stdout is not None
    url = None
    deadline = time.monotonic() + 30
    while url is None and time.monotonic() < deadline:
        line = process.stdout.readline()
        match = re.search(r"(http://127\.0\.0\.1:\d+)/", line)
        if match:
            url = match.group(1)
    assert url, "the sim did not print its address"
    try:
        yield url
    finally:
        process.terminate()
        process.wait(timeout=10)


WAIT = 30.0  # seconds at most for what the robot does: a bound, not a pace (a loaded machine is slow)


def wait_for_state(url: str, state: str) -> dict[str, object]:
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        with urllib.request.urlopen(url + "/api/status") as response:
            status = json.loads(response.read())
        if status["state"] == state:
            return status  # type: ignore[no-any-return]
        time.sleep(0.05)
    raise AssertionError(f"never reached {state}")


def test_event_say_emotion_and_status(running_sim: str) -> None:
    url = running_sim
    wait_for_state(url, "idle")
    result = tool(url, "event", "music_play")
    assert result.returncode == 0 and "sent event music_play" in result.stdout
    status = wait_for_state(url, "music")
    assert status["previous_state"] == "idle" and status["event"] == "music_play"
    assert tool(url, "say", "hello", "there").stdout.strip() == "heard: hello there"
    heard: list[str] = []
    deadline = time.monotonic() + WAIT
    while "hello there" not in heard and time.monotonic() < deadline:  # the robot heard it, not only the tool
        with urllib.request.urlopen(url + "/api/records?type=heard") as answer:
            heard = [record["text"] for record in json.loads(answer.read())]
        time.sleep(0.05)
    assert "hello there" in heard
    # Each command's emotion is published at once; the music state's feedback moves it on later
    # (sooner on a loaded machine), so the emotion records show it, and the status its form.
    assert tool(url, "emotion", "set", "angry").returncode == 0
    wait_for_emotion(url, "angry", (-0.51, 0.59, 0.25))
    shown = tool(url, "status").stdout
    assert "idle --music_play--> music" in shown and "emotion " in shown and "(P " in shown
    assert tool(url, "emotion", "values", "0.5", "0.4", "0.2").returncode == 0
    wait_for_emotion(url, None, (0.5, 0.4, 0.2))
    said = tool(url, "emotion", "set", "sadness").stdout  # table 2.2's bracketed word
    assert said.strip() == "emotion set to inhibited (you typed sadness)"
    wait_for_emotion(url, "inhibited", (-0.54, -0.04, -0.33))


def wait_for_emotion(url: str, name: str | None, pad: tuple[float, float, float]) -> None:
    """Wait (WAIT s at most) for an emotion record of ``name`` (any name: None) at ``pad``."""
    deadline = time.monotonic() + WAIT
    while True:
        with urllib.request.urlopen(url + "/api/records?type=emotion") as answer:
            records = json.loads(answer.read())
        if any(
            (name is None or r["emotion"] == name)
            and (round(r["pleasure"], 2), round(r["arousal"], 2), round(r["dominance"], 2)) == pad
            for r in records
        ):
            return
        assert time.monotonic() < deadline, f"no emotion {name} at {pad} in {records[-5:]}"
        time.sleep(0.05)


def test_bad_input_is_refused_with_the_reason(running_sim: str) -> None:
    result = tool(running_sim, "emotion", "values", "0.5", "3", "0")
    assert result.returncode != 0
    assert "'AROUSAL': 3.0 is outside [-1, 1]" in result.stderr
    values = json.dumps({"pleasure": 0.5, "arousal": 3, "dominance": 0}).encode()
    as_json = {"Content-Type": "application/json"}  # commands take only JSON (docs/security.md)
    request = urllib.request.Request(running_sim + "/api/emotion/values", data=values, headers=as_json)
    with pytest.raises(urllib.error.HTTPError) as info:
        urllib.request.urlopen(request)
    assert (
        info.value.code == 400
        and "'arousal' must be a number in [-1, 1], got 3" in info.value.read().decode()
    )
    request = urllib.request.Request(running_sim + "/api/event", data=b"not json", headers=as_json)
    with pytest.raises(urllib.error.HTTPError) as info:
        urllib.request.urlopen(request)
    assert info.value.code == 400 and "not usable JSON" in info.value.read().decode()


def test_no_robot_running_is_explained() -> None:
    result = tool("http://127.0.0.1:9", "status")
    assert result.returncode != 0 and "no robot answers" in result.stderr and "cyborg sim" in result.stderr


def test_openapi_document_lists_the_commands(running_sim: str) -> None:
    with urllib.request.urlopen(running_sim + "/api/openapi.json") as response:
        spec = json.loads(response.read())
    assert spec["openapi"].startswith("3.")
    assert {"/api/event", "/api/say", "/api/emotion/set", "/api/status"} <= set(spec["paths"])


def test_status_reports_the_gatekeepers_counts(running_cyborg: str) -> None:
    url = running_cyborg
    wait_for_state(url, "idle")
    tool(url, "say", "hello")
    wait_for_state(url, "conversation")
    deadline = time.monotonic() + 20
    while True:
        with urllib.request.urlopen(url + "/api/status") as response:
            counts = json.loads(response.read())["gatekeepers"]["cyborg_speech_gatekeeper"]
        if counts["passed"] >= 1 or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    assert counts["resource"] == "speech" and counts["passed"] >= 1, counts
    shown = tool(url, "status").stdout.splitlines()
    line = next(x for x in shown if "gatekeeper cyborg_speech_gatekeeper" in x)
    assert re.search(r"\(speech, held by \w+\): passed \d+, dropped \d+", line), line
