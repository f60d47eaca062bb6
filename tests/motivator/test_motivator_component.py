"""The motivator on the transport, and a simulated day of an otherwise idle robot."""

from __future__ import annotations

import json
from pathlib import Path

from cyborg.controller.config import parse_config
from cyborg.sim.robot import build_robot
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String, SystemState

CONFIG = """
states:
  idle:
    action: cyborg_idle/idle
    transitions: {music_play: music, joke_tell: joke, aborted: idle}
  music:
    action: cyborg_music/play
    transitions: {succeeded: idle, aborted: idle, joke_tell: joke}
  joke:
    action: cyborg_joke/tell
    transitions: {succeeded: idle, aborted: idle}
modules:
  cyborg_idle: {kind: idle, interval: 5}
  cyborg_music: {kind: placeholder, servers: [{action: cyborg_music/play, duration: 60}]}
  cyborg_joke: {kind: placeholder, servers: [{action: cyborg_joke/tell, say: "A joke.", duration: 5}]}
motivator:
  rate_seconds: 2
  events:
    - {state: idle, event: music_play, reward_pleasure: 0.10, reward_arousal: 0.05}
    - {state: idle, event: joke_tell, reward_pleasure: 0.05, reward_arousal: 0.05, reward_dominance: 0.05}
    - {state: music, event: joke_tell, reward_pleasure: 0.0, reward_arousal: 0.0, reward_dominance: -0.5}
"""
IDLE_LIMIT = 120.0


class Watch:
    def __init__(self, transport: EmbeddedTransport) -> None:
        node = transport.node("watch")
        self.changes: list[tuple[float, SystemState]] = []
        self.decisions: list[dict[str, object]] = []
        self.clock = transport.clock
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_change, queue_size=1000)
        node.subscribe(topics.MOTIVATOR_DECISION, String, self._on_decision, queue_size=1000)
        self.events_seen: list[tuple[str, str]] = []
        node.subscribe(topics.REGISTER_EVENT, String, self._on_event, queue_size=1000)
        self.state = ""

    def _on_change(self, m: SystemState, info: MessageInfo) -> None:
        self.changes.append((self.clock.monotonic(), m))
        self.state = m.to_system_state

    def _on_decision(self, m: String, info: MessageInfo) -> None:
        self.decisions.append(json.loads(m.data))

    def _on_event(self, m: String, info: MessageInfo) -> None:
        if info.sender == "cyborg_motivator":
            self.events_seen.append((self.state, m.data))


def run(hours: float, tmp_path: Path) -> tuple[Watch, dict[str, int]]:
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    robot = build_robot(parse_config(CONFIG), transport, data_dir=tmp_path)
    watch = Watch(transport)
    robot.start()
    try:
        clock.run(clock.sleep(hours * 3600))
    finally:
        clock.close()
    return watch, dict(robot.motivator.chosen)


def test_motivator_only_emits_transitions_of_the_active_state(tmp_path: Path) -> None:
    watch, _ = run(0.5, tmp_path)
    machine = parse_config(CONFIG).machine
    assert watch.events_seen, "the motivator never chose anything"
    for state, event in watch.events_seen:
        assert event in machine.transitions_of(state), f"{event} sent in {state}"


def test_decisions_explain_candidates_and_nothing_chosen(tmp_path: Path) -> None:
    watch, _ = run(0.5, tmp_path)
    chosen = [d for d in watch.decisions if d["event"]]
    refused = [d for d in watch.decisions if not d["event"]]
    assert chosen and refused
    for decision in chosen + refused:
        assert decision["candidates"] and decision["reason"]
        for candidate in decision["candidates"]:  # type: ignore[attr-defined]
            assert set(candidate) >= {"event", "reward", "cost", "net", "eligible"}
    assert any("reward <= cost" in str(d["reason"]) for d in refused)


def test_eight_idle_hours_keep_the_robot_busy_and_varied(tmp_path: Path) -> None:
    watch, chosen = run(8, tmp_path)
    total = sum(chosen.values())
    assert total > 50
    assert max(chosen.values()) / total <= 0.8, chosen
    entered_idle = None
    longest_idle = 0.0
    for t, change in watch.changes:
        if change.to_system_state == "idle":
            entered_idle = t
        elif entered_idle is not None:
            longest_idle = max(longest_idle, t - entered_idle)
            entered_idle = None
    assert longest_idle <= IDLE_LIMIT, f"idle for {longest_idle:.0f} s"


def test_saturations_survive_a_restart(tmp_path: Path) -> None:
    _, chosen = run(0.2, tmp_path)
    assert chosen
    from cyborg.emotion.store import ControllerStore

    saturations = ControllerStore(tmp_path / "controller.db").get_saturations()
    assert any(value > 0 for value in saturations.values())
