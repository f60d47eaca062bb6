"""The emotion system on a full disk: it goes on in memory, says so once, and saves when it can (issue 12, item 4)."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from cyborg.emotion.model import EmotionSettings, HalfLives
from cyborg.emotion.system import EmotionSystem
from cyborg.motivator.store import ControllerStore
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import EmotionalFeedback, EmotionalState, String
from tests.support.full_disk import Disk

HALVES = HalfLives(pleasure=10.0, arousal=10.0, dominance=10.0)


class Robot:
    """An emotion system on a store whose disk can fill up, and a node that talks to it."""

    def __init__(self, clock: VirtualClock, tmp_path: Path, settings: EmotionSettings) -> None:
        self.clock = clock
        self.path = tmp_path / "controller.db"
        transport = EmbeddedTransport(clock)
        self.store = ControllerStore(self.path, clock=clock)
        self.disk = Disk(self.store)
        self.system = EmotionSystem(transport.node("cyborg_emotion"), settings, self.store)
        node = transport.node("probe")
        self.states: list[EmotionalState] = []
        node.subscribe(topics.EMOTIONAL_STATE, EmotionalState, self._on_state, queue_size=1000)
        self.feedback = node.publisher(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback).publish
        self.set_name = node.publisher(topics.SET_EMOTIONAL_STATE, String).publish
        self.set_values = node.publisher(topics.SET_EMOTIONAL_VALUES, EmotionalFeedback).publish
        self.switch = node.publisher(topics.EMOTIONAL_CONTROLLER, String).publish

    def _on_state(self, m: EmotionalState, info: MessageInfo) -> None:
        self.states.append(m)

    def run(self, seconds: float) -> None:
        self.clock.run(self.clock.sleep(seconds))

    def on_disk(self) -> tuple[tuple[float, float, float], bool]:
        stored = ControllerStore(self.path).get_emotion()  # another connection: what a restart reads
        return tuple(round(v, 3) for v in stored.pad.as_tuple()), stored.enabled  # type: ignore[return-value]


def warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]


def test_commands_and_feedback_change_the_emotion_while_the_disk_is_full_and_are_saved_after(
    clock: VirtualClock, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    robot = Robot(clock, tmp_path, EmotionSettings())
    robot.disk.fill()

    robot.set_name(String("angry"))
    robot.run(0.1)
    assert robot.states[-1].to_emotional_state == "angry"  # published: the dashboard and modules see it
    robot.feedback(EmotionalFeedback(0.3, 0.0, 0.0))
    robot.run(0.1)
    assert robot.states[-1].current_pleasure == pytest.approx(-0.51 + 0.51**3 * 0.15 + 0.3)
    robot.set_values(EmotionalFeedback(0.5, 0.5, 0.5))
    robot.switch(String("off"))
    robot.run(0.1)
    assert robot.system.pad.as_tuple() == (0.5, 0.5, 0.5) and robot.system.enabled is False

    status = robot.store.save_status
    assert not status.saved
    assert status.problem == f"could not save the PAD values in {robot.path}: database or disk is full"
    assert status.fix == "free some space on that disk (or give another folder with --data-dir)"
    assert status.unsaved == ("the PAD values", "the emotion system's switch")
    assert robot.on_disk() == ((0.0, 0.0, 0.0), True)  # nothing reached the file

    robot.run(30.0)  # tried every second: still one warning for the whole episode, no traceback
    assert len(warnings(caplog)) == 1, warnings(caplog)
    assert "database or disk is full; fix: free some space on that disk" in warnings(caplog)[0]
    assert not any(r.exc_info for r in caplog.records)

    robot.disk.free()
    robot.run(1.5)
    assert robot.store.save_status.saved and robot.store.save_status.unsaved == ()
    assert robot.on_disk() == ((0.5, 0.5, 0.5), False)  # the state in memory is written
    assert "writes work again" in warnings(caplog)[-1] and len(warnings(caplog)) == 2


def test_the_time_decay_goes_on_through_a_full_disk_and_is_saved_after(
    clock: VirtualClock, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    robot = Robot(clock, tmp_path, EmotionSettings(time_decay_half_lives=HALVES))
    robot.set_values(EmotionalFeedback(0.8, 0.8, 0.8))
    robot.run(0.1)
    robot.disk.fill()
    robot.run(10.0)  # one half-life with every save failing
    assert robot.system.pad.pleasure == pytest.approx(0.4, abs=0.02)
    published = len(robot.states)
    robot.disk.free()
    robot.run(10.0)  # and another once it can save again
    assert robot.system.pad.pleasure == pytest.approx(0.2, abs=0.02)
    assert len(robot.states) > published + 5, "the decay stopped publishing"
    assert robot.on_disk()[0][0] == pytest.approx(0.2, abs=0.02)
    assert len(warnings(caplog)) == 2  # the full disk, then writes working again


def test_closing_the_store_makes_a_last_try_and_names_what_is_lost(
    clock: VirtualClock, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    robot = Robot(clock, tmp_path, EmotionSettings())
    robot.disk.fill()
    robot.set_name(String("angry"))
    robot.run(0.1)
    robot.system.close()
    robot.store.close()
    assert f"controller store {robot.path} closed with the PAD values not saved" in warnings(caplog)[-1]
