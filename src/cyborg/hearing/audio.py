"""Audio in: WAV files and chunks, and the microphone (ALSA through PortAudio, with ``sounddevice``).

Everything becomes 16 kHz 16-bit mono, what the recogniser takes. A missing audio library or
microphone is a :class:`~cyborg.hearing.HearingError` that names the fix.
"""

from __future__ import annotations

import io
import math
import wave
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from cyborg.hearing import HearingError
from cyborg.hearing.recogniser import SAMPLE_RATE

__all__ = ["Microphone", "probe_microphone", "read_wav", "to_recogniser_rate", "wav_bytes"]

NO_PORTAUDIO = (
    "the audio library PortAudio is missing ({detail}); fix: run scripts/install-system-deps "
    "(or apt-get install libportaudio2), or give a recording with --wav FILE"
)
NO_MICROPHONE = (
    "no microphone to listen to ({detail}); fix: plug one in (check with 'arecord -l'), name another "
    "one with the device setting / --device, or give a recording with --wav FILE"
)


def to_recogniser_rate(samples: Any, rate: int) -> bytes:
    """Mono int16 ``samples`` at ``rate`` as 16 kHz 16-bit bytes."""
    data = np.asarray(samples)
    if rate != SAMPLE_RATE:
        from scipy.signal import resample_poly

        common = math.gcd(rate, SAMPLE_RATE)
        data = resample_poly(data.astype(np.float32), SAMPLE_RATE // common, rate // common)
    return bytes(np.clip(data, -32768, 32767).astype("<i2").tobytes())


def wav_bytes(data: bytes, what: str = "the recording") -> bytes:
    """A WAV file's content as 16 kHz 16-bit mono bytes; channels are mixed down."""
    try:
        with wave.open(io.BytesIO(data)) as wav:
            width, channels, rate = wav.getsampwidth(), wav.getnchannels(), wav.getframerate()
            frames = wav.readframes(wav.getnframes())
    except (wave.Error, EOFError) as exc:
        raise HearingError(f"{what} is not a WAV file ({exc}); fix: give a 16-bit PCM WAV") from exc
    if width != 2:
        raise HearingError(f"{what} has {8 * width}-bit samples; fix: give a 16-bit PCM WAV")
    samples = np.frombuffer(frames, dtype="<i2").reshape(-1, channels).mean(axis=1)
    return to_recogniser_rate(samples, rate)


def read_wav(path: Path) -> bytes:
    """The WAV file at ``path`` as 16 kHz 16-bit mono bytes."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise HearingError(f"cannot read {path}: {exc.strerror}; fix: give a WAV file that exists") from exc
    return wav_bytes(data, str(path))


class Microphone:
    """Records from an input device and hands each block of 16 kHz bytes to ``on_audio`` (another thread)."""

    def __init__(self, on_audio: Callable[[bytes], None], *, device: str | int | None = None) -> None:
        try:
            import sounddevice
        except OSError as exc:
            raise HearingError(NO_PORTAUDIO.format(detail=exc)) from exc
        self._on_audio = on_audio
        try:
            info = sounddevice.query_devices(device, "input")
            self.rate = int(info["default_samplerate"]) if info else SAMPLE_RATE
            self._stream = sounddevice.RawInputStream(
                samplerate=self.rate, channels=1, dtype="int16", device=device, callback=self._callback
            )
            self._stream.start()
        except (sounddevice.PortAudioError, ValueError) as exc:
            raise HearingError(NO_MICROPHONE.format(detail=exc)) from exc
        self.name = str(info["name"]) if info else "default"

    def _callback(self, data: Any, frames: int, time: Any, status: Any) -> None:
        samples = np.frombuffer(bytes(data), dtype="<i2")
        self._on_audio(to_recogniser_rate(samples, self.rate) if self.rate != SAMPLE_RATE else bytes(data))

    def close(self) -> None:
        """Stop recording."""
        self._stream.stop()
        self._stream.close()


def probe_microphone(device: str | int | None = None) -> str:
    """The name of the input device the robot would listen to; a HearingError naming the fix when
    there is none. It is looked up, not opened: the ears' node may hold it open right now."""
    try:
        import sounddevice
    except OSError as exc:
        raise HearingError(NO_PORTAUDIO.format(detail=exc)) from exc
    try:
        info = sounddevice.query_devices(device, "input")
    except (sounddevice.PortAudioError, ValueError) as exc:
        raise HearingError(NO_MICROPHONE.format(detail=exc)) from exc
    if not info or not int(info.get("max_input_channels", 0)):
        raise HearingError(NO_MICROPHONE.format(detail=f"{device or 'the default device'} records nothing"))
    return str(info["name"])
