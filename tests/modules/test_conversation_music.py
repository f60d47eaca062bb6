"""Greeting detection, the conversation's quiet timeout, and the generated tune."""

from __future__ import annotations

import os
import sys
import types
import wave
from pathlib import Path

import pytest

from cyborg.modules.conversation import ConversationModule, is_greeting
from cyborg.modules.music import MUSIC_ACTION, MusicModule, synthesise
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus
from cyborg.transport.clock import RealClock, VirtualClock
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


def _music_goal(
    clock: VirtualClock | RealClock, module_player: tuple[str, ...] | None
) -> tuple[GoalStatus, float, MusicModule]:
    transport = EmbeddedTransport(clock)
    music = MusicModule(transport.node("cyborg_music"), play_audio=False)
    music.player = module_player
    client = transport.node("controller").action_client(MUSIC_ACTION, StateMachineAction)

    async def main() -> tuple[GoalStatus, float]:
        handle = client.send_goal(StateMachineGoal("idle", "music_play", "music"))
        await clock.sleep(1.0)
        cancelled = clock.monotonic()
        handle.cancel()
        status = await handle.wait()
        return status, clock.monotonic() - cancelled

    status, took = clock.run(main())
    return status, took, music


def test_music_stops_the_moment_it_is_preempted(clock: VirtualClock) -> None:
    status, took, music = _music_goal(clock, None)
    assert music.duration > 3  # it would have played on
    assert status is GoalStatus.PREEMPTED and took == 0.0


def test_music_kills_its_player_when_preempted() -> None:
    clock = RealClock()
    try:
        # A stand-in player that would play for 30 s (the tune's path comes as its argument).
        player = (sys.executable, "-c", "import time; time.sleep(30)")
        before = {p.pid for p in live_children()}
        status, took, _ = _music_goal(clock, player)
    finally:
        clock.close()
    assert status is GoalStatus.PREEMPTED and took < 1.0
    assert {p.pid for p in live_children()} <= before, "the player process is gone"


def live_children() -> list[types.SimpleNamespace]:
    """This process's live child processes (from /proc), as objects with a pid."""
    me = str(os.getpid())
    children = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[1] == me and fields[0] != "Z":
            children.append(types.SimpleNamespace(pid=int(entry.name)))
    return children
