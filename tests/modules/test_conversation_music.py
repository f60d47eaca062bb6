"""Greeting detection, the conversation's quiet timeout, and the generated tune.

The modules run in :class:`cyborg.testing.ModuleHarness`, as a module author's would; only the
real player process, which needs real time, gets a transport of its own.
"""

from __future__ import annotations

import os
import sys
import types
import wave
from pathlib import Path

import pytest

from cyborg.modules.conversation import CONVERSATION_KIND, is_greeting
from cyborg.modules.music import KIND as MUSIC_KIND
from cyborg.modules.music import MUSIC_ACTION, MUSIC_FEEDBACK, MusicModule, synthesise
from cyborg.testing import GoalStatus, ModuleHarness
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import StateMachineAction, StateMachineGoal


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("hello", True),
        ("Hello!", True),
        ("hi there", True),
        ("Good morning, Cyborg", True),
        ("hey", True),
        ("Nice to see you.", True),  # a greeting whose "hey" the ears lost
        ("it was nice to see you", False),
        ("where is the cafeteria?", False),
        ("this is a hit", False),
        ("", False),
        ("go to entrance 2", False),
    ],
)
def test_greetings(text: str, expected: bool) -> None:
    assert is_greeting(text) is expected


def test_greeting_asks_for_conversation_and_quiet_ends_it() -> None:
    with ModuleHarness(CONVERSATION_KIND, {"quiet_seconds": 30}, node_name="cyborg_conversation") as robot:
        robot.hear("Hello!")
        assert robot.events == ["conversation_interest"]
        goal = robot.start(event="conversation_interest")
        robot.run(20)
        robot.hear("what a nice day", then=0)  # keeps the conversation going
        robot.run(29.8)
        assert not goal.done, "30 quiet seconds count from the last sentence heard"
        robot.run(0.4)
        assert goal.status is GoalStatus.SUCCEEDED
        assert robot.events == ["conversation_interest"], "only a greeting asks for the conversation"


def test_tune_is_a_real_wav(tmp_path: Path) -> None:
    duration = synthesise(tmp_path / "tune.wav")
    with wave.open(str(tmp_path / "tune.wav")) as wav:
        assert wav.getnchannels() == 1 and wav.getframerate() == 22050
        assert wav.getnframes() / wav.getframerate() == pytest.approx(duration)
    assert 3 < duration < 15


def test_music_stops_the_moment_it_is_preempted() -> None:
    with ModuleHarness(MUSIC_KIND, {"play_audio": False}, node_name="cyborg_music") as robot:
        music = robot.module
        assert isinstance(music, MusicModule) and music.duration > 3  # it would play on
        goal = robot.start(event="music_play")
        robot.run(1.0)
        goal.cancel()
        robot.run(0)
        assert goal.status is GoalStatus.PREEMPTED, "the preemption is acknowledged at once"
        assert [f.pad for f in robot.feedback] == [MUSIC_FEEDBACK]


def test_music_kills_its_player_when_preempted() -> None:
    """A real player process in real time: beyond ModuleHarness, whose clock is virtual."""
    clock = RealClock()
    try:
        transport = EmbeddedTransport(clock)
        music = MusicModule(transport.node("cyborg_music"), play_audio=False)
        # A stand-in player that would play for 30 s (the tune's path comes as its argument).
        music.player = (sys.executable, "-c", "import time; time.sleep(30)")
        client = transport.node("controller").action_client(MUSIC_ACTION, StateMachineAction)
        before = {p.pid for p in live_children()}

        async def main() -> tuple[GoalStatus, float]:
            handle = client.send_goal(StateMachineGoal("idle", "music_play", "music"))
            await clock.sleep(1.0)
            cancelled = clock.monotonic()
            handle.cancel()
            status = await handle.wait()
            return status, clock.monotonic() - cancelled

        status, took = clock.run(main())
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
