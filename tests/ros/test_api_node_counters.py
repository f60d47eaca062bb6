"""Issue 12, item 8: under ROS the dashboard's counters of dropped (invalid) and overflowing
events are the controller's, not zeros: `cyborg node cyborg_api` reads them from the
controller node's latched /cyborg_controller/stats."""

from __future__ import annotations

import json
import time
import urllib.request
from pathlib import Path
from typing import Any

from tests.support.ros import Observers, Processes, free_port, yaml_path


def health(port: int) -> dict[str, Any]:
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=5) as response:
        answer: dict[str, Any] = json.loads(response.read())
    return answer


def test_the_api_node_shows_the_controllers_dropped_events(
    processes: Processes, observe: Observers, tmp_path: Path
) -> None:
    config = yaml_path("faults.yaml")
    changes = observe.state_changes()
    events = observe.events()
    port = free_port()
    idle = processes.cyborg_node("cyborg_test_idle", config, tmp_path)
    controller = processes.cyborg_node("cyborg_controller", config, tmp_path)
    api = processes.cyborg_node("cyborg_api", config, tmp_path, "--port", str(port))
    processes.wait_ready(idle, controller, api)
    changes.wait_state("idle", event="start")
    events.wait_connected()

    for _ in range(3):
        events.send("no_such_event")  # not a transition of idle: the controller drops it
    deadline = time.monotonic() + 20
    stats = health(port)["stats"]
    while stats["events_invalid"] < 3 and time.monotonic() < deadline:
        time.sleep(0.2)
        stats = health(port)["stats"]
    assert stats["events_invalid"] == 3 and stats["events_received"] >= 3, stats
    assert stats["events_overflow"] == 0 and stats["handovers"] >= 1, stats
