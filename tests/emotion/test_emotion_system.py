"""The emotion system on the transport: feedback, controls, service, persistence."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cyborg.emotion.model import EmotionSettings, HalfLives
from cyborg.emotion.store import ControllerStore
from cyborg.emotion.system import EmotionSystem
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import EmotionalFeedback, EmotionalState, EmotionalStateService, String


class Probe:
    def __init__(self, transport: EmbeddedTransport) -> None:
        self.node = transport.node("probe")
        self.states: list[EmotionalState] = []
        self.node.subscribe(topics.EMOTIONAL_STATE, EmotionalState, self._on_state, queue_size=1000)
        self.feedback = self.node.publisher(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback).publish
        self.set_name = self.node.publisher(topics.SET_EMOTIONAL_STATE, String).publish
        self.set_values = self.node.publisher(topics.SET_EMOTIONAL_VALUES, EmotionalFeedback).publish
        self.switch = self.node.publisher(topics.EMOTIONAL_CONTROLLER, String).publish

    def _on_state(self, m: EmotionalState, info: MessageInfo) -> None:
        self.states.append(m)


def make(
    clock: VirtualClock, tmp_path: Path, **settings: object
) -> tuple[EmbeddedTransport, EmotionSystem, Probe]:
    transport = EmbeddedTransport(clock)
    store = ControllerStore(tmp_path / "controller.db")
    system = EmotionSystem(transport.node("cyborg_emotion"), EmotionSettings(**settings), store)  # type: ignore[arg-type]
    return transport, system, Probe(transport)


def test_feedback_updates_and_publishes(clock: VirtualClock, tmp_path: Path) -> None:
    _, system, probe = make(clock, tmp_path)
    probe.feedback(EmotionalFeedback(0.2, -0.1, 0.0))
    clock.run(clock.sleep(0.1))
    last = probe.states[-1]
    # 0 - 0^3 * 0.15 + 0.2 = 0.2
    assert last.current_pleasure == pytest.approx(0.2)
    assert last.current_arousal == pytest.approx(-0.1)
    assert system.stats.updates == 1


def test_set_by_name_then_service_reports_it(clock: VirtualClock, tmp_path: Path) -> None:
    transport, _, probe = make(clock, tmp_path)
    probe.set_name(String("angry"))
    clock.run(clock.sleep(0.1))
    assert probe.states[-1].to_emotional_state == "angry"
    answer = clock.run(
        transport.node("asker").service_proxy(topics.GET_EMOTIONAL_STATE, EmotionalStateService).call()
    )
    assert answer.emotional_state == "angry"
    assert answer.current_pleasure == pytest.approx(-0.51)


def test_bad_feedback_is_rejected_and_counted(clock: VirtualClock, tmp_path: Path) -> None:
    _, system, probe = make(clock, tmp_path)
    for bad in (
        EmotionalFeedback(math.nan, 0, 0),
        EmotionalFeedback(0, math.inf, 0),
        EmotionalFeedback(0, 0, 2.5),
    ):
        probe.feedback(bad)
    probe.set_name(String("furious"))
    probe.set_values(EmotionalFeedback(1.5, 0, 0))
    clock.run(clock.sleep(0.1))
    assert system.stats.rejected == 5
    assert system.pad.as_tuple() == (0.0, 0.0, 0.0)


def test_switched_off_ignores_feedback(clock: VirtualClock, tmp_path: Path) -> None:
    _, system, probe = make(clock, tmp_path)
    probe.switch(String("off"))
    clock.run(clock.sleep(0.1))
    probe.feedback(EmotionalFeedback(0.5, 0.5, 0.5))
    clock.run(clock.sleep(0.1))
    assert system.pad.as_tuple() == (0.0, 0.0, 0.0) and system.stats.ignored_while_off == 1
    probe.switch(String("on"))
    clock.run(clock.sleep(0.1))
    probe.feedback(EmotionalFeedback(0.5, 0.0, 0.0))
    clock.run(clock.sleep(0.1))
    assert system.pad.pleasure == pytest.approx(0.5)


def test_state_and_switch_survive_a_restart(tmp_path: Path) -> None:
    clock = VirtualClock()
    _, _, probe = make(clock, tmp_path)
    probe.set_values(EmotionalFeedback(0.3, -0.2, 0.1))
    probe.switch(String("off"))
    clock.run(clock.sleep(0.1))
    clock.close()
    clock2 = VirtualClock()
    transport2 = EmbeddedTransport(clock2)
    restarted = EmotionSystem(
        transport2.node("cyborg_emotion"), EmotionSettings(), ControllerStore(tmp_path / "controller.db")
    )
    assert restarted.pad.as_tuple() == pytest.approx((0.3, -0.2, 0.1))
    assert restarted.enabled is False
    clock2.close()


def test_time_decay_also_covers_the_time_the_robot_was_off(tmp_path: Path) -> None:
    halves = {"time_decay_half_lives": HalfLives(pleasure=100.0, arousal=100.0, dominance=100.0)}
    clock = VirtualClock(start=1_000_000.0)
    _, _, probe = make(clock, tmp_path, **halves)
    probe.set_values(EmotionalFeedback(0.8, 0.0, 0.0))
    clock.run(clock.sleep(0.01))
    clock.close()
    later = VirtualClock(start=1_000_000.0 + 200.0)  # off for 200 s = two half-lives
    transport = EmbeddedTransport(later)
    store = ControllerStore(tmp_path / "controller.db")
    restarted = EmotionSystem(transport.node("cyborg_emotion"), EmotionSettings(**halves), store)  # type: ignore[arg-type]
    assert restarted.pad.pleasure == pytest.approx(0.2, abs=0.01)
    later.close()


def test_time_decay_runs_without_feedback(clock: VirtualClock, tmp_path: Path) -> None:
    _, system, probe = make(clock, tmp_path, time_decay_half_lives=HalfLives(pleasure=10.0))
    probe.set_values(EmotionalFeedback(0.8, 0.4, 0.0))
    clock.run(clock.sleep(10.05))
    assert system.pad.pleasure == pytest.approx(0.4, abs=0.01)
    assert system.pad.arousal == pytest.approx(0.4)  # no half-life for arousal
