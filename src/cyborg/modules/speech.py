"""Text-to-speech output module.

Speaks one sentence at a time from a bounded queue. Every sentence is logged
and published on ``/cyborg_tts/spoken`` (what the robot actually said, after
the gatekeeper). It speaks only what a gatekeeper passed: with ``speak_from`` (the
configured gatekeepers in front of it) a sentence another node publishes on its input
topic is ignored, and one over the API's text limit too (each logged once per sender).
With an audio device it speaks through espeak-ng; it can also
write each sentence to a WAV file. A sentence occupies the speaker for its
estimated duration on the injected clock, so virtual time behaves like real.
Registered as the module kind ``tts``.
"""

from __future__ import annotations

import asyncio
import glob
import logging
import os
import shutil
from collections import deque
from dataclasses import dataclass
from pathlib import Path

from cyborg.modules.kind import BuildContext, KindSettings, ModuleKind, setting
from cyborg.modules.problems import ProblemReporter
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.guards import OnlyFrom, TextLimit
from cyborg.transport.messages import String
from cyborg.transport.topics import SPEECH_INPUT_TOPIC, SPOKEN_TOPIC

log = logging.getLogger(__name__)

SPOKEN_KEPT = 1000  # sentences remembered in memory (every one is logged and published)
WORDS_PER_SECOND = 2.6


def audio_device_present() -> bool:
    return bool(glob.glob("/dev/snd/pcmC*p")) or "PULSE_SERVER" in os.environ


SOUND_RETRY = 30.0
"""Seconds after a failed sound output before the speaker is tried again (plugged back in)."""
NO_SOUND_FIX = (
    "fix: plug in the speaker and check it with `aplay -l` and `speaker-test -c 2 -l 1`, or set the "
    "module's play_audio: false; meanwhile the robot goes on and what it says shows on the dashboard"
)


def sound_failure(returncode: int | None, stderr: str) -> str | None:
    """What went wrong when espeak-ng spoke (None: it played). espeak-ng exits 0 even when it cannot
    open the sound device; it then says ``error:`` (and ALSA explains on stderr)."""
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    errors = [
        line for line in lines if line.lower().startswith(("error", "alsa lib")) or "pcm" in line.lower()
    ]
    if not returncode and not errors:
        return None
    detail = errors[-1] if errors else f"exit code {returncode}"
    return f"no sound output: espeak-ng could not play on the default sound device ({detail})"


def probe_sound_output(espeak: str | None = None, timeout: float = 10.0) -> str | None:
    """Play a silent word on the default sound device; what is wrong with the fix, or None."""
    import subprocess

    espeak = espeak or shutil.which("espeak-ng")
    if espeak is None:
        return "espeak-ng is not installed; fix: run scripts/setup (or apt-get install espeak-ng)"
    try:
        done = subprocess.run(
            [espeak, "-a", "0", "-v", "en", "ok"], capture_output=True, text=True, timeout=timeout
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"espeak-ng could not run ({exc}); fix: reinstall espeak-ng"
    problem = sound_failure(done.returncode, done.stderr)
    return None if problem is None else f"{problem}; {NO_SOUND_FIX}"


def estimated_duration(text: str) -> float:
    return 0.4 + len(text.split()) / WORDS_PER_SECOND


class TextToSpeech:
    """Subscribes to ``input_topic`` and speaks what arrives, in order."""

    def __init__(
        self,
        node: Node,
        *,
        input_topic: str = SPEECH_INPUT_TOPIC,
        queue_size: int = 10,
        play_audio: bool | None = None,
        wav_dir: Path | None = None,
        voice: str = "en",
        speak_from: tuple[str, ...] = (),
    ) -> None:
        """``speak_from``: the only nodes whose sentences it speaks (empty: any node's)."""
        self.node = node
        self.senders = OnlyFrom(speak_from, input_topic, "sentences") if speak_from else None
        self.too_long = TextLimit(input_topic)
        self.queue: deque[str] = deque()
        self.queue_size = queue_size
        self.dropped = 0
        self.spoken: deque[str] = deque(maxlen=SPOKEN_KEPT)  # the latest sentences, for tests and status
        self.sentences = 0
        self.voice = voice
        self.espeak = shutil.which("espeak-ng")
        wants_audio = audio_device_present() if play_audio is None else play_audio
        self.play_audio = bool(wants_audio and self.espeak and not node.clock.is_virtual)
        self.sound_problem: str | None = None
        """Why the last sentence was not heard (no sound device), until the speaker works again."""
        self._sound_retry_at = -float("inf")
        if play_audio and not self.espeak:
            self.sound_problem = (
                "espeak-ng is not installed; fix: run scripts/setup (or apt-get install espeak-ng)"
            )
        self.wav_dir = wav_dir
        if wav_dir is not None:
            wav_dir.mkdir(parents=True, exist_ok=True)
        self._wake = asyncio.Event()
        self._spoken_pub = node.publisher(SPOKEN_TOPIC, String)
        self.problems = ProblemReporter(node)
        if self.sound_problem is not None:
            what, _, fix = self.sound_problem.partition("; fix: ")
            self.problems.report(f"the robot cannot speak aloud: {what}", fix, key="sound")
        node.subscribe(input_topic, String, self._on_text)
        self._task = node.clock.loop.create_task(self._speak_loop(), name="tts")

    def close(self) -> None:
        """Stop speaking; what is still queued is not said."""
        self._task.cancel()

    def _on_text(self, message: String, info: MessageInfo) -> None:
        if self.senders is not None and not self.senders.accepts(info.sender):
            return
        text = message.data.strip()
        if not text or not self.too_long.accepts(text, info.sender):
            return
        if len(self.queue) >= self.queue_size:
            self.queue.popleft()
            self.dropped += 1
            log.warning("speech queue full: dropped the oldest sentence")
        self.queue.append(text)
        self._wake.set()

    async def _speak_loop(self) -> None:
        while True:
            while not self.queue:
                self._wake.clear()
                await self._wake.wait()
            text = self.queue.popleft()
            await self._speak(text)

    async def _speak(self, text: str) -> None:
        log.info("saying: %s", text)
        self.spoken.append(text)
        self.sentences += 1
        self._spoken_pub.publish(String(data=text))
        if self.wav_dir is not None and self.espeak:
            path = self.wav_dir / f"{self.sentences:04d}.wav"
            problem = await self._espeak("-w", str(path), text)
            if problem is not None:
                log.warning("could not write %s: %s", path, problem)
        clock = self.node.clock
        if self.play_audio and (self.sound_problem is None or clock.monotonic() >= self._sound_retry_at):
            started = clock.monotonic()
            problem = await self._espeak(text)
            if problem is None:
                if self.sound_problem is not None:
                    log.warning("sound output works again: the robot speaks aloud")
                    self.problems.clear("sound")
                self.sound_problem = None
                return
            if self.sound_problem is None:  # said once per outage, not per sentence
                self.problems.report(
                    f"the robot cannot speak aloud: {problem}",
                    NO_SOUND_FIX.removeprefix("fix: "),
                    key="sound",
                )
            self.sound_problem, self._sound_retry_at = problem, clock.monotonic() + SOUND_RETRY
            await clock.sleep(max(0.0, estimated_duration(text) - (clock.monotonic() - started)))
        else:
            await clock.sleep(estimated_duration(text))

    async def _espeak(self, *args: str) -> str | None:
        """Run espeak-ng with ``args``; what went wrong playing (None: fine)."""
        assert self.espeak is not None
        try:
            process = await asyncio.create_subprocess_exec(
                self.espeak,
                "-v",
                self.voice,
                *args,
                stdout=asyncio.subprocess.DEVNULL,
                stderr=asyncio.subprocess.PIPE,
            )
            _, err = await process.communicate()
        except OSError as exc:
            return f"espeak-ng could not run: {exc}"
        return sound_failure(process.returncode, err.decode(errors="replace"))


@dataclass(frozen=True, kw_only=True)
class TtsSettings(KindSettings):
    """Text-to-speech: says what passes the speech gatekeeper, one sentence at a time (espeak-ng)."""

    queue_size: int = setting(10, ge=1, description="sentences waiting at most; the oldest is dropped")
    play_audio: bool | None = setting(
        None, description="speak on the speakers (default: when an audio device is present)"
    )
    wav_dir: str | None = setting(None, description="folder to write each sentence to as a WAV file")
    voice: str = setting("en", description="espeak-ng voice")


def _build(node: Node, settings: TtsSettings, context: BuildContext) -> TextToSpeech:
    return TextToSpeech(
        node,
        queue_size=settings.queue_size,
        play_audio=settings.play_audio,
        wav_dir=Path(settings.wav_dir) if settings.wav_dir else None,
        voice=settings.voice,
        speak_from=context.relays_to(SPEECH_INPUT_TOPIC) or (),
    )


KIND = ModuleKind(TtsSettings, _build)
