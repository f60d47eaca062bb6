"""Speech made by speech synthesisers (espeak-ng, flite), for tests and benchmarks of the ears.

No recording is kept in the repository: every utterance is synthesised when needed, padded
with quiet noise (a microphone is never digitally silent) and optionally noisier.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cyborg.hearing import HearingError
from cyborg.hearing.audio import read_wav

__all__ = ["VOICES", "Voice", "as_heard", "as_heard_chunks", "synthesise"]


@dataclass(frozen=True)
class Voice:
    """A synthesiser, its voice and its speed (espeak-ng: words per minute; flite: duration stretch)."""

    engine: str
    name: str
    rate: float

    def __str__(self) -> str:
        return f"{self.engine}:{self.name}@{self.rate:g}"


VOICES = (
    Voice("espeak-ng", "en", 160),
    Voice("espeak-ng", "en-us", 130),
    Voice("espeak-ng", "en+f3", 190),
    Voice("flite", "slt", 1.0),
    Voice("flite", "kal", 1.2),
    Voice("flite", "awb", 0.9),
    Voice("flite", "rms", 1.0),
)


def synthesise(text: str, voice: Voice, *, noise: float = 30.0, pad: float = 0.3, seed: int = 0) -> bytes:
    """``text`` said by ``voice`` as 16 kHz 16-bit mono bytes, with ``pad`` seconds of noise either side.

    ``noise`` is the standard deviation of the added white noise in sample units (of 32768).
    """
    program = shutil.which(voice.engine)
    if program is None:
        raise HearingError(f"{voice.engine} is not installed; fix: run scripts/install-system-deps --test")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "speech.wav"
        if voice.engine == "flite":
            command = [
                program,
                "-voice",
                voice.name,
                "--setf",
                f"duration_stretch={voice.rate}",
                "-t",
                text,
                "-o",
                str(path),
            ]
        else:
            command = [program, "-v", voice.name, "-s", str(int(voice.rate)), "-w", str(path), text]
        subprocess.run(command, check=True, capture_output=True, timeout=30)
        samples = np.frombuffer(read_wav(path), dtype="<i2").astype(np.float32)
    return as_heard(samples, noise=noise, pad=pad, seed=seed)


def as_heard(audio: bytes | np.ndarray, *, noise: float = 30.0, pad: float = 0.3, seed: int = 0) -> bytes:
    """16 kHz 16-bit ``audio`` as a microphone in the room hears it: ``pad`` seconds of quiet either
    side and white noise of standard deviation ``noise`` (a synthesiser's digital silence is not speech
    the recogniser knows)."""
    samples = np.frombuffer(audio, dtype="<i2") if isinstance(audio, bytes) else audio
    quiet = np.zeros(int(pad * 16000), np.float32)
    heard = np.concatenate([quiet, samples.astype(np.float32), quiet])
    heard += np.random.default_rng(seed).normal(0.0, noise, len(heard)).astype(np.float32)
    return bytes(np.clip(heard, -32768, 32767).astype("<i2").tobytes())


def as_heard_chunks(
    chunks: Iterable[bytes], *, noise: float = 30.0, pad: float = 0.3, seed: int = 0
) -> Iterator[bytes]:
    """:func:`as_heard` of a recording given in chunks (:func:`~cyborg.hearing.audio.wav_chunks`),
    a chunk at a time: the quiet before, each chunk with its noise, the quiet after."""
    rng = np.random.default_rng(seed)
    quiet = np.zeros(int(pad * 16000), np.float32)

    def noisy(samples: np.ndarray) -> bytes:
        heard = samples.astype(np.float32) + rng.normal(0.0, noise, len(samples)).astype(np.float32)
        return bytes(np.clip(heard, -32768, 32767).astype("<i2").tobytes())

    yield noisy(quiet)
    for chunk in chunks:
        yield noisy(np.frombuffer(chunk, dtype="<i2"))
    yield noisy(quiet)
