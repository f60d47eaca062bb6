"""Greeting detection, the conversation's quiet timeout, and the generated tune."""

from __future__ import annotations

import wave
from pathlib import Path

import pytest

from cyborg.modules.conversation import ConversationModule, is_greeting
from cyborg.modules.music import synthesise
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import StateMachineAction, StateMachineGoal, String


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("hello", True),
        ("Hello!", True),
        ("hi there", True),
        ("Good morning, Cyborg", True),
        ("hey", True),
        ("where is the cafeteria?", False),
        ("this is a hit", False),
        ("", False),
        ("go to entrance 2", False),
    ],
)
def test_greetings(text: str, expected: bool) -> None:
    assert is_greeting(text) is expected


def test_greeting_asks_for_conversation_and_quiet_ends_it(clock: VirtualClock) -> None:
    transport = EmbeddedTransport(clock)
    ConversationModule(transport.node("cyborg_conversation"), quiet_seconds=30)
    probe = transport.node("probe")
    events: list[str] = []
    probe.subscribe(topics.REGISTER_EVENT, String, lambda m, i: events.append(m.data))
    speech = probe.publisher(topics.TEXT_FROM_SPEECH, String)
    client = probe.action_client("cyborg_conversation/conversation", StateMachineAction)

    async def main() -> tuple[GoalStatus, float]:
        speech.publish(String("Hello!"))
        await clock.sleep(0.1)
        start = clock.monotonic()
        handle = client.send_goal(StateMachineGoal("idle", "conversation_interest", "conversation"))
        await clock.sleep(20)
        speech.publish(String("what a nice day"))  # keeps the conversation going
        status = await handle.wait()
        return status, clock.monotonic() - start

    status, lasted = clock.run(main())
    assert events == ["conversation_interest"]
    assert status is GoalStatus.SUCCEEDED
    assert lasted == pytest.approx(50.0, abs=0.2)


def test_tune_is_a_real_wav(tmp_path: Path) -> None:
    duration = synthesise(tmp_path / "tune.wav")
    with wave.open(str(tmp_path / "tune.wav")) as wav:
        assert wav.getnchannels() == 1 and wav.getframerate() == 22050
        assert wav.getnframes() / wav.getframerate() == pytest.approx(duration)
    assert 3 < duration < 15
