"""The emotion system on the transport: feedback, controls, service, persistence."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cyborg.emotion.model import EmotionSettings, HalfLives
from cyborg.emotion.system import EmotionSystem
from cyborg.motivator.store import ControllerStore
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


START = 1_000_000.0


def stored_angry_and_off(tmp_path: Path) -> None:
    """A first run that ends angry with the emotion system switched off, at START + 0.1."""
    clock = VirtualClock(start=START)
    _, _, probe = make(clock, tmp_path)
    probe.set_name(String("angry"))
    probe.switch(String("off"))
    clock.run(clock.sleep(0.1))
    clock.close()


def start_again(tmp_path: Path, after: float, *, resume: bool, **settings: object) -> EmotionSystem:
    clock = VirtualClock(start=START + after)
    transport = EmbeddedTransport(clock)
    system = EmotionSystem(
        transport.node("cyborg_emotion"),
        EmotionSettings(**settings),  # type: ignore[arg-type]
        ControllerStore(tmp_path / "controller.db"),
        resume=resume,
    )
    clock.close()
    return system


def test_a_fresh_start_is_neutral_and_on_whatever_was_stored(tmp_path: Path) -> None:
    stored_angry_and_off(tmp_path)
    fresh = start_again(tmp_path, 5.0, resume=False)
    assert (fresh.emotion, fresh.pad.as_tuple(), fresh.enabled, fresh.resumed) == (
        "neutral",
        (0.0, 0.0, 0.0),
        True,
        False,
    )
    # the store now holds the fresh start, so a crash right after it does not bring anger back
    again = start_again(tmp_path, 6.0, resume=True)
    assert (again.emotion, again.enabled) == ("neutral", True)


def test_a_controller_back_after_a_crash_resumes_a_recent_emotion(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    stored_angry_and_off(tmp_path)
    with caplog.at_level("INFO", logger="cyborg.emotion.system"):
        back = start_again(tmp_path, 60.0, resume=True)
    assert (back.emotion, back.enabled, back.resumed) == ("angry", False, True)
    assert back.pad.as_tuple() == pytest.approx((-0.51, 0.59, 0.25))
    assert any("resumed the stored emotion angry" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize(
    ("after", "settings", "why"),
    [
        (301.0, {}, "more than resume_within_seconds (300 s)"),
        (1.0, {"resume_within_seconds": 0.0}, "resuming is off"),
    ],
)
def test_an_old_emotion_or_resuming_switched_off_starts_neutral(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, after: float, settings: dict[str, object], why: str
) -> None:
    stored_angry_and_off(tmp_path)
    with caplog.at_level("INFO", logger="cyborg.emotion.system"):
        back = start_again(tmp_path, after, resume=True, **settings)
    assert (back.emotion, back.enabled, back.resumed) == ("neutral", True, False)
    assert any(why in r.getMessage() for r in caplog.records), [r.getMessage() for r in caplog.records]


def test_a_resumed_emotion_decays_for_the_time_the_controller_was_off(tmp_path: Path) -> None:
    halves = {"time_decay_half_lives": HalfLives(pleasure=100.0, arousal=100.0, dominance=100.0)}
    clock = VirtualClock(start=1_000_000.0)
    _, _, probe = make(clock, tmp_path, **halves)
    probe.set_values(EmotionalFeedback(0.8, 0.0, 0.0))
    clock.run(clock.sleep(0.01))
    clock.close()
    later = VirtualClock(start=1_000_000.0 + 200.0)  # off for 200 s = two half-lives
    transport = EmbeddedTransport(later)
    store = ControllerStore(tmp_path / "controller.db")
    restarted = EmotionSystem(transport.node("cyborg_emotion"), EmotionSettings(**halves), store, resume=True)  # type: ignore[arg-type]
    assert restarted.pad.pleasure == pytest.approx(0.2, abs=0.01)
    later.close()


def test_time_decay_runs_without_feedback(clock: VirtualClock, tmp_path: Path) -> None:
    _, system, probe = make(clock, tmp_path, time_decay_half_lives=HalfLives(pleasure=10.0))
    probe.set_values(EmotionalFeedback(0.8, 0.4, 0.0))
    clock.run(clock.sleep(10.05))
    assert system.pad.pleasure == pytest.approx(0.4, abs=0.01)
    assert system.pad.arousal == pytest.approx(0.4)  # no half-life for arousal


def test_the_wire_carries_the_names_of_table_2_2(clock: VirtualClock, tmp_path: Path) -> None:
    """A module written against the thesis tests for "elated", "inhibited" and "puzzled"."""
    transport, _, probe = make(clock, tmp_path)
    asker = transport.node("asker").service_proxy(topics.GET_EMOTIONAL_STATE, EmotionalStateService)
    for point, name in [
        ((0.50, 0.42, 0.23), "elated"),
        ((-0.54, -0.04, -0.33), "inhibited"),
        ((-0.41, 0.48, -0.33), "puzzled"),
    ]:
        probe.set_values(EmotionalFeedback(*point))
        clock.run(clock.sleep(0.1))
        assert probe.states[-1].to_emotional_state == name
        assert clock.run(asker.call()).emotional_state == name


@pytest.mark.parametrize(
    ("typed", "published"),
    [("happy", "elated"), ("Sadness", "inhibited"), ("sad", "inhibited"), (" surprised ", "puzzled")],
)
def test_the_bracketed_words_are_accepted_where_a_person_types_an_emotion(
    clock: VirtualClock, tmp_path: Path, typed: str, published: str
) -> None:
    _, system, probe = make(clock, tmp_path)
    probe.set_name(String(typed))
    clock.run(clock.sleep(0.1))
    assert probe.states[-1].to_emotional_state == published
    assert system.stats.rejected == 0


def test_an_unknown_emotion_name_lists_the_names_and_the_aliases() -> None:
    with pytest.raises(ValueError, match="unknown emotion 'furious'") as error:
        EmotionSettings().resolve("furious")
    assert "elated" in str(error.value) and "happy for elated" in str(error.value)
