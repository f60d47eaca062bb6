"""The motivator on the transport, and a simulated day of an otherwise idle robot."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest

from cyborg.app.config import parse_config
from cyborg.app.robot import Robot, build_robot, controller_busy
from cyborg.motivator.store import ControllerStore
from cyborg.testing.idle_day import IdleDay, IdleDayReport, idle_spells, run_idle_day
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import EmotionalFeedback, EmotionalState, String, SystemState

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
  cyborg_joke: {kind: placeholder, servers: [{action: cyborg_joke/tell, say: "A joke.", duration: 15}]}
motivator:
  rate_seconds: 2
  events:
    - {state: idle, event: music_play, reward_pleasure: 0.10, reward_arousal: 0.05}
    - {state: idle, event: joke_tell, reward_pleasure: 0.05, reward_arousal: 0.05, reward_dominance: 0.05}
    - {state: music, event: joke_tell, reward_pleasure: 0.0, reward_arousal: 0.0, reward_dominance: -0.5}
"""
REWARDS = {
    ("idle", "music_play"): (0.10, 0.05, 0.0),
    ("idle", "joke_tell"): (0.05, 0.05, 0.05),
    ("music", "joke_tell"): (0.0, 0.0, -0.5),
}

# idle ignores a cancel, so a handover out of idle takes the whole preempt timeout (3 s)
SLOW_HANDOVER = """
timeouts: {connect: 2.0, preempt: 3.0}
states:
  idle: {action: cyborg_idle/idle, transitions: {go: busy, music_play: music, aborted: idle}}
  busy: {action: cyborg_busy/work, transitions: {music_play: music, succeeded: idle, aborted: idle}}
  music: {action: cyborg_music/play, transitions: {succeeded: idle, aborted: idle}}
modules:
  cyborg_idle: {kind: placeholder, servers: [{action: cyborg_idle/idle, honour_cancel: false}]}
  cyborg_busy: {kind: placeholder, servers: [{action: cyborg_busy/work, duration: 100}]}
  cyborg_music: {kind: placeholder, servers: [{action: cyborg_music/play, duration: 10}]}
motivator:
  rate_seconds: 2
  min_seconds_in_state: 10
  events:
    - {state: idle, event: music_play, reward_pleasure: 0.1}
"""


class Watch:
    def __init__(self, transport: EmbeddedTransport) -> None:
        node = transport.node("watch")
        self.changes: list[tuple[float, SystemState]] = []
        self.decisions: list[dict[str, object]] = []
        self.clock = transport.clock
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_change, queue_size=1000)
        node.subscribe(topics.MOTIVATOR_DECISION, String, self._on_decision, queue_size=1000)
        self.events_seen: list[tuple[str, str]] = []
        self.feedback: list[tuple[float, float, float]] = []
        node.subscribe(topics.REGISTER_EVENT, String, self._on_event, queue_size=1000)
        node.subscribe(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback, self._on_feedback, queue_size=1000)
        self.state = ""

    def _on_change(self, m: SystemState, info: MessageInfo) -> None:
        self.changes.append((self.clock.monotonic(), m))
        self.state = m.to_system_state

    def _on_decision(self, m: String, info: MessageInfo) -> None:
        self.decisions.append(json.loads(m.data))

    def _on_event(self, m: String, info: MessageInfo) -> None:
        if info.sender == "cyborg_motivator":
            self.events_seen.append((self.state, m.data))

    def _on_feedback(self, m: EmotionalFeedback, info: MessageInfo) -> None:
        if info.sender == "cyborg_motivator":
            self.feedback.append((m.delta_pleasure, m.delta_arousal, m.delta_dominance))

    def transitions(self) -> list[tuple[str, str, str]]:
        return [(c.from_system_state, c.event, c.to_system_state) for _, c in self.changes]


def start(config: str, tmp_path: Path) -> tuple[VirtualClock, EmbeddedTransport, Robot, Watch]:
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    robot = build_robot(parse_config(config), transport, data_dir=tmp_path)
    watch = Watch(transport)
    robot.start()
    return clock, transport, robot, watch


def run(hours: float, tmp_path: Path) -> tuple[Watch, dict[str, int]]:
    clock, _, robot, watch = start(CONFIG, tmp_path)
    try:
        clock.run(clock.sleep(hours * 3600))
    finally:
        robot.close()  # a restart reads what the closed robot stored
        clock.close()
    return watch, dict(robot.motivator.chosen)


def test_motivator_only_emits_transitions_of_the_active_state(tmp_path: Path) -> None:
    watch, _ = run(0.5, tmp_path)
    machine = parse_config(CONFIG).machine
    assert watch.events_seen, "the motivator never chose anything"
    for state, event in watch.events_seen:
        assert event in machine.transitions_of(state), f"{event} sent in {state}"


def test_each_choice_sends_its_reward_as_emotional_feedback(tmp_path: Path) -> None:
    watch, _ = run(0.5, tmp_path)
    assert set(watch.events_seen) == {("idle", "music_play"), ("idle", "joke_tell")}
    assert watch.feedback == [REWARDS[seen] for seen in watch.events_seen]


def test_decisions_explain_candidates_and_nothing_chosen(tmp_path: Path) -> None:
    watch, _ = run(0.5, tmp_path)
    chosen = [d for d in watch.decisions if d["event"]]
    refused = [d for d in watch.decisions if not d["event"]]
    assert chosen and refused
    for decision in chosen:
        assert decision["status"] == "chosen" and decision["reason"] and decision["candidates"]
        for candidate in decision["candidates"]:  # type: ignore[attr-defined]
            assert set(candidate) >= {"event", "reward", "cost", "net", "eligible"}
    by_status: dict[object, list[dict[str, object]]] = {}
    for decision in refused:
        assert decision["reason"], decision
        by_status.setdefault(decision["status"], []).append(decision)
    # joke has no events; music's only event never pays (its reward is negative); a new state waits
    assert set(by_status) == {"no_events", "not_worth_it", "not_ready"}
    assert {d["state"] for d in by_status["no_events"]} == {"joke"}
    assert {d["state"] for d in by_status["not_worth_it"]} == {"music"}
    assert all("reward <= 0" in str(d["reason"]) for d in by_status["not_worth_it"])
    assert all("min_seconds_in_state" in str(d["reason"]) for d in by_status["not_ready"])


def test_nothing_chosen_is_logged_at_info_only_when_the_reason_changes(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG, logger="cyborg.motivator.component")
    watch, _ = run(0.5, tmp_path)
    logged = [r for r in caplog.records if "chose nothing" in r.getMessage()]
    expected_info = 0
    previous: tuple[object, object] | None = None
    for decision in watch.decisions:
        key = None if decision["event"] else (decision["status"], decision["state"])
        expected_info += key is not None and key != previous
        previous = key
    refused = [d for d in watch.decisions if not d["event"]]
    assert len(logged) == len(refused) > 100
    assert sum(r.levelno == logging.INFO for r in logged) == expected_info < len(refused) / 3
    assert all(r.levelno in (logging.INFO, logging.DEBUG) for r in logged)


def test_no_event_while_another_modules_handover_is_in_progress(tmp_path: Path) -> None:
    # "go" arrives at 9.5 s; idle ignores the cancel, so the controller hands over until 12.5 s.
    # The motivator is ready from 10 s: an event sent at 10 or 12 s would be queued and then
    # applied to busy, which also has music_play.
    clock, transport, robot, watch = start(SLOW_HANDOVER, tmp_path)
    events = transport.node("someone").publisher(topics.REGISTER_EVENT, String)
    clock.loop.call_later(9.5, lambda: events.publish(String(data="go")))
    try:
        clock.run(clock.sleep(40))
    finally:
        clock.close()
    assert watch.transitions() == [("", "start", "idle"), ("idle", "go", "busy")]
    assert robot.motivator.chosen == {}
    waits = [d for d in watch.decisions if d["status"] == "handover"]
    assert [d["state"] for d in waits] == ["idle", "idle"]
    assert "event 'go' from someone" in str(waits[0]["reason"])


def test_controller_busy_reports_the_handover_and_holds_the_motivator(tmp_path: Path) -> None:
    clock, transport, robot, watch = start(SLOW_HANDOVER, tmp_path)
    busy = controller_busy(robot.controller)
    events = transport.node("someone").publisher(topics.REGISTER_EVENT, String)
    seen: list[tuple[float, bool]] = []
    clock.loop.call_later(9.5, lambda: events.publish(String(data="go")))

    def note(t: float) -> None:
        seen.append((t, busy()))

    for t in (5.0, 11.0, 20.0):
        clock.loop.call_later(t, note, t)
    try:
        clock.run(clock.sleep(25))
    finally:
        clock.close()
    assert seen == [(5.0, False), (11.0, True), (20.0, False)]

    clock, _, robot, watch = start(SLOW_HANDOVER, tmp_path / "held")
    robot.motivator.controller_busy = lambda: True
    try:
        clock.run(clock.sleep(40))
    finally:
        clock.close()
    assert robot.motivator.chosen == {}
    assert watch.decisions and {d["status"] for d in watch.decisions} == {"handover"}


def test_idle_spells_count_the_one_still_running_at_the_end() -> None:
    changes = [(0.0, "", "idle"), (30.0, "idle", "music"), (90.0, "music", "idle"), (95.0, "idle", "idle")]
    assert idle_spells(changes, end=400.0) == [30.0, 310.0]
    assert idle_spells([(0.0, "", "idle")], end=3600.0) == [3600.0]


def test_a_day_idle_at_the_end_misses_the_goal() -> None:
    day = IdleDay(hours=1, idle_limit_seconds=120)
    report = IdleDayReport(day, {"a": 5, "b": 5}, [30.0, 3000.0], 0.1, [])
    assert report.problems() == ["idle for 3000 s at a time, over the limit of 120 s"]


def test_eight_idle_hours_keep_the_robot_busy_and_varied(tmp_path: Path) -> None:
    report = run_idle_day(tmp_path)
    assert report.day == IdleDay()  # the same day benchmarks/bench_idle_day.py runs
    assert report.total > 50
    assert report.problems() == []
    assert report.longest_idle <= report.day.idle_limit_seconds


def test_saturations_survive_a_restart(tmp_path: Path) -> None:
    _, chosen = run(0.2, tmp_path)
    assert chosen
    saturations = ControllerStore(tmp_path / "controller.db").get_saturations()
    assert any(value > 0 for value in saturations.values())


def test_an_event_the_controller_did_not_take_gives_no_reward_and_no_saturation(tmp_path: Path) -> None:
    """Another module's event reaches the controller in the same instant as the motivator's choice
    (as the scheduler's did at t = 10 s in scenario C): only the event taken counts."""
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    other = transport.node("cyborg_music_fan").publisher(topics.REGISTER_EVENT, String)
    # due at the motivator's first decision (10 s in idle), and queued before it
    clock.call_later(10.0, lambda: other.publish(String(data="music_play")))
    config = CONFIG.replace(
        "{succeeded: idle, aborted: idle, joke_tell: joke}", "{succeeded: idle, aborted: idle}"
    )
    config = config.replace(
        "    - {state: music, event: joke_tell, reward_pleasure: 0.0, reward_arousal: 0.0, reward_dominance: -0.5}\n",
        "",
    )
    robot = build_robot(parse_config(config), transport, data_dir=tmp_path)
    watch = Watch(transport)
    robot.start()
    try:
        clock.run(clock.sleep(10.5))
        assert watch.events_seen == [("idle", "joke_tell")], "the motivator did choose the joke"
        assert watch.transitions()[-1] == ("idle", "music_play", "music"), "the other event came first"
        assert watch.feedback == [], "no reward for a joke that was never told"
        assert robot.motivator.saturations.get("joke_tell", 0.0) == 0.0
        assert robot.motivator.not_taken == {"joke_tell": 1} and robot.motivator.chosen == {}
        assert robot.store.get_saturations().get("joke_tell", 0.0) == 0.0
        clock.run(clock.sleep(80.0))  # back in idle after the music: a choice taken is rewarded
        taken = [e for e in watch.events_seen if e[0] == "idle"]
        assert robot.motivator.chosen and len(watch.feedback) == sum(robot.motivator.chosen.values())
        assert watch.feedback[0] == REWARDS[taken[1]]
    finally:
        clock.close()


def test_the_motivator_decides_and_rewards_while_the_disk_is_full(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Issue 12, item 4: saving the saturations fails, yet the robot goes on (in memory) and saves later."""
    from tests.support.full_disk import Disk

    clock, _, robot, watch = start(CONFIG, tmp_path)
    disk = Disk(robot.store)
    disk.fill()
    emotions: list[float] = []
    robot.emotion.node.subscribe(
        topics.EMOTIONAL_STATE, EmotionalState, lambda m, i: emotions.append(m.current_pleasure)
    )
    try:
        clock.run(clock.sleep(600))
        assert robot.motivator.chosen, "the motivator stopped choosing"
        assert len(watch.feedback) == sum(robot.motivator.chosen.values())
        assert robot.emotion.stats.updates >= len(watch.feedback) and len(set(emotions)) > 10
        assert len(watch.decisions) > 100
        in_memory = dict(robot.motivator.saturations)
        assert any(in_memory.values())
        robot.store.flush()  # its thread gathers saves for 20 ms of real time: 600 virtual s may be less
        status = robot.store.save_status
        assert not status.saved and "the motivator's saturations" in status.unsaved
        assert ControllerStore(tmp_path / "controller.db").get_saturations() == {}
        assert [r.levelname for r in caplog.records if r.levelno >= logging.WARNING] == ["WARNING"]

        disk.free()
        clock.run(clock.sleep(1.5))
        robot.store.flush()  # the store writes on its own thread, in real time
        assert robot.store.save_status.saved
        stored = ControllerStore(tmp_path / "controller.db").get_saturations()
        # those of the last reward (they are saved at a reward; in memory they decline between)
        assert stored.keys() == in_memory.keys()
        assert all(stored[event] >= in_memory[event] > 0 for event in stored)
    finally:
        clock.close()
