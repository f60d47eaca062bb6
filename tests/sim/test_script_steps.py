"""Issue 30, item 2: after a step's record matched, every later record is seen by the next step,
also those that came in the same loop turn as the matching one."""

from __future__ import annotations

from cyborg.observe.records import Record
from cyborg.sim.scenario import ScenarioDriver
from cyborg.sim.script import parse_script
from cyborg.transport import topics
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import EmotionalState, String


def drive(text: str, *, at: float = 5.0) -> ScenarioDriver:
    """Run ``text`` against a fake robot that, at ``at``, sends an emotion and then a sentence
    from one callback (so both records arrive in one loop turn, as a module's goal sends them)."""
    clock = VirtualClock(speed=None)
    transport = EmbeddedTransport(clock)
    robot = transport.node("fake_robot")
    emotion = robot.publisher(topics.EMOTIONAL_STATE, EmotionalState)
    spoken = robot.publisher(topics.SPOKEN_TOPIC, String)

    def speak() -> None:
        emotion.publish(EmotionalState(to_emotional_state="pleased", current_pleasure=0.05))
        spoken.publish(String("It is 15:29."))

    driver = ScenarioDriver(transport.node("cyborg_scenario"), parse_script(text, source="t.yaml"))
    try:
        clock.call_later(at, speak)
        clock.run(driver.run())
    finally:
        transport.shutdown()
        clock.close()
    return driver


def types(records: list[Record]) -> list[str]:
    return [str(record["type"]) for record in records]


def test_a_say_in_the_same_loop_turn_as_the_expected_emotion_meets_the_next_expect() -> None:
    driver = drive(
        """
until: 10
steps:
  - {expect: {type: emotion, pleasure: 0.05}, within: 6}
  - {expect: {type: say, contains: "It is 15:29."}, within: 1}
"""
    )
    assert types(driver.records) == ["emotion", "say"], "both came in one turn"
    assert driver.failures == []
