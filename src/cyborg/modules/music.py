"""The music module: plays a short generated tune and stops the moment it is preempted.

The tune is synthesised into a WAV file (numpy + the standard ``wave``
module). With an audio device and a player (aplay, paplay or ffplay) it is
played for real; otherwise the state simply lasts the tune's duration on the
injected clock. Registered as the module kind ``music``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import shutil
import tempfile
import wave
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cyborg.modules.behaviour import BehaviourModule, GoalContext
from cyborg.modules.kind import BuildContext, KindSettings, ModuleKind, setting
from cyborg.modules.speech import audio_device_present
from cyborg.transport.base import Node

log = logging.getLogger(__name__)

MUSIC_ACTION = "cyborg_music/play"
SAMPLE_RATE = 22050
# (MIDI note, beats): a short, cheerful phrase
TUNE: tuple[tuple[int, float], ...] = (
    (67, 1),
    (72, 1),
    (76, 1),
    (79, 2),
    (76, 1),
    (79, 3),
    (74, 1),
    (77, 1),
    (81, 1),
    (79, 2),
    (77, 1),
    (76, 3),
)
PLAYERS = (("aplay", "-q"), ("paplay",), ("ffplay", "-nodisp", "-autoexit", "-loglevel", "quiet"))


def synthesise(path: Path, *, tempo: float = 150.0, tune: tuple[tuple[int, float], ...] = TUNE) -> float:
    """Write ``tune`` as a 16-bit mono WAV file; return its duration in seconds."""
    beat = 60.0 / tempo
    pieces = []
    for note, beats in tune:
        n = int(SAMPLE_RATE * beats * beat)
        t = np.arange(n) / SAMPLE_RATE
        frequency = 440.0 * 2 ** ((note - 69) / 12)
        envelope = np.minimum(1.0, np.minimum(t / 0.01, (n / SAMPLE_RATE - t) / 0.05))
        tone = np.sin(2 * np.pi * frequency * t) + 0.3 * np.sin(4 * np.pi * frequency * t)
        pieces.append(0.3 * envelope * tone)
    samples = np.concatenate(pieces)
    with wave.open(str(path), "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(SAMPLE_RATE)
        out.writeframes((samples * 32767).astype("<i2").tobytes())
    return len(samples) / SAMPLE_RATE


def find_player() -> tuple[str, ...] | None:
    for player in PLAYERS:
        if shutil.which(player[0]):
            return player
    return None


MUSIC_FEEDBACK = (0.0, 0.05, -0.12)
"""PAD change when a tune starts: stirring and a little humbling, which makes the robot curious
(thesis 10.2.1 observation 2, 10.2.2 observation 3)."""


class MusicModule(BehaviourModule):
    def __init__(
        self,
        node: Node,
        *,
        action: str = MUSIC_ACTION,
        tune_dir: Path | None = None,
        play_audio: bool | None = None,
        feedback: tuple[float, float, float] = MUSIC_FEEDBACK,
    ) -> None:
        super().__init__(node)
        self.feedback = feedback
        directory = tune_dir or Path(tempfile.gettempdir())
        directory.mkdir(parents=True, exist_ok=True)
        self.tune_path = directory / "cyborg-tune.wav"
        self.duration = synthesise(self.tune_path)
        wants_audio = audio_device_present() if play_audio is None else play_audio
        self.player = find_player() if wants_audio and not node.clock.is_virtual else None
        self.plays = 0
        self.serve(action, self.play)

    async def play(self, ctx: GoalContext) -> None:
        self.plays += 1
        self.send_emotion(*self.feedback)
        if self.player is None:
            await ctx.sleep(self.duration)
            return
        process = await asyncio.create_subprocess_exec(
            *self.player,
            str(self.tune_path),
            stdout=asyncio.subprocess.DEVNULL,
            stderr=asyncio.subprocess.DEVNULL,
        )
        try:
            await process.wait()
        finally:
            if process.returncode is None:
                with contextlib.suppress(ProcessLookupError):
                    process.kill()
                await process.wait()  # gone before the preemption is acknowledged, even on a loaded machine


@dataclass(frozen=True, kw_only=True)
class MusicSettings(KindSettings):
    """Plays a short generated tune (on the speakers when there are any); stops when preempted."""

    action: str = setting(MUSIC_ACTION, description="action server of the music state")
    play_audio: bool | None = setting(
        None, description="play on the speakers (default: when an audio device is present)"
    )
    feedback: tuple[float, float, float] = setting(
        MUSIC_FEEDBACK, description="PAD change when a tune starts"
    )


def _build(node: Node, settings: MusicSettings, context: BuildContext) -> MusicModule:
    return MusicModule(
        node,
        action=settings.action,
        tune_dir=context.data_dir,
        play_audio=settings.play_audio,
        feedback=settings.feedback,
    )


KIND = ModuleKind(MusicSettings, _build)
