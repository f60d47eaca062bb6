"""Audio in: WAV files and chunks, and the microphone (ALSA through PortAudio, with ``sounddevice``).

Everything becomes 16 kHz 16-bit mono, what the recogniser takes. A recording is read, mixed
down and resampled :data:`CHUNK_SECONDS` at a time (:func:`wav_chunks`), so an hour costs the
memory of those seconds, not of the hour. A missing audio library or microphone is a
:class:`~cyborg.hearing.HearingError` that names the fix.
"""

from __future__ import annotations

import io
import math
import wave
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from cyborg.hearing import HearingError
from cyborg.hearing.recogniser import SAMPLE_RATE

__all__ = [
    "CHUNK_SECONDS",
    "Microphone",
    "probe_microphone",
    "read_wav",
    "to_recogniser_rate",
    "wav_bytes",
    "wav_chunks",
]

NO_PORTAUDIO = (
    "the audio library PortAudio is missing ({detail}); fix: run scripts/install-system-deps "
    "(or apt-get install libportaudio2), or give a recording with --wav FILE"
)
NO_MICROPHONE = (
    "no microphone to listen to ({detail}); fix: plug one in (check with 'arecord -l'), name another "
    "one with the device setting / --device, or give a recording with --wav FILE"
)


MIN_RATE = 4_000
MAX_RATE = 192_000
"""Sample rates a recording may have (a header claiming 0 or 4,000,000,007 Hz is broken, not audio)."""
CHUNK_SECONDS = 10.0
"""Seconds of a recording read and converted at a time."""
READ_BYTES = 1 << 22
"""Most bytes of a WAV file read at once."""


def to_recogniser_rate(samples: Any, rate: int) -> bytes:
    """Mono int16 ``samples`` at ``rate`` (MIN_RATE to MAX_RATE) as 16 kHz 16-bit bytes."""
    if not MIN_RATE <= rate <= MAX_RATE:
        raise HearingError(
            f"a sample rate of {rate:,} Hz is not usable audio; fix: give a recording at {MIN_RATE:,} to "
            f"{MAX_RATE:,} Hz (16,000 is what the recogniser takes)"
        )
    data = np.asarray(samples)
    if rate != SAMPLE_RATE:
        from scipy.signal import resample_poly

        common = math.gcd(rate, SAMPLE_RATE)
        data = resample_poly(data.astype(np.float32), SAMPLE_RATE // common, rate // common)
    return bytes(np.clip(data, -32768, 32767).astype("<i2").tobytes())


def wav_bytes(data: bytes, what: str = "the recording") -> bytes:
    """A WAV file's content as 16 kHz 16-bit mono bytes; channels are mixed down."""
    return b"".join(_converted(_open_wav(io.BytesIO(data), what), what))


def read_wav(path: Path) -> bytes:
    """The WAV file at ``path`` as 16 kHz 16-bit mono bytes."""
    return b"".join(wav_chunks(path))


def wav_chunks(path: Path, seconds: float = CHUNK_SECONDS) -> Iterator[bytes]:
    """The WAV file at ``path`` as 16 kHz 16-bit mono bytes, about ``seconds`` at a time.

    The file is opened and its header checked at once (a HearingError here, before any model
    loads); the samples are read as the chunks are taken."""
    try:
        handle = path.open("rb")
    except OSError as exc:
        raise HearingError(f"cannot read {path}: {exc.strerror}; fix: give a WAV file that exists") from exc
    try:
        wav = _open_wav(handle, str(path))
    except BaseException:
        handle.close()
        raise
    return _closing(handle, _converted(wav, str(path), seconds))


def _closing(handle: io.BufferedReader, chunks: Iterator[bytes]) -> Iterator[bytes]:
    with handle:
        yield from chunks


def _open_wav(source: IO[bytes], what: str) -> wave.Wave_read:
    """``source`` opened as a WAV file whose samples this module can convert."""
    try:
        wav = wave.open(source, "rb")  # noqa: SIM115  (read by the caller; the file is the caller's to close)
    except (wave.Error, EOFError) as exc:
        raise HearingError(f"{what} is not a WAV file ({exc}); fix: give a 16-bit PCM WAV") from exc
    width, rate = wav.getsampwidth(), wav.getframerate()
    if width != 2:
        raise HearingError(f"{what} has {8 * width}-bit samples; fix: give a 16-bit PCM WAV")
    if not MIN_RATE <= rate <= MAX_RATE:
        raise HearingError(
            f"{what} claims a sample rate of {rate:,} Hz (its header is broken, or it is no recording); "
            f"fix: give a 16-bit PCM WAV at {MIN_RATE:,} to {MAX_RATE:,} Hz (16,000 is best)"
        )
    return wav


def _converted(wav: wave.Wave_read, what: str, seconds: float = CHUNK_SECONDS) -> Iterator[bytes]:
    """The samples of ``wav`` mixed down and at 16 kHz, a block at a time.

    A block is resampled with ``margin`` input samples of its neighbours on either side, more than
    the resampling filter reaches, and only its own part of the result is kept: the chunks join
    to exactly what resampling the whole recording gives. Blocks and margins are whole multiples
    of ``down`` input samples, so each maps to a whole number of output samples."""
    rate, channels = wav.getframerate(), wav.getnchannels()
    common = math.gcd(rate, SAMPLE_RATE)
    up, down = SAMPLE_RATE // common, rate // common
    block = down * max(1, math.ceil(seconds * rate / down))
    margin = 0 if up == down else down * math.ceil((10 * max(up, down) / up + 2) / down)
    buffer = np.zeros(0, dtype=np.float64)  # input samples from buffer_start on
    buffer_start = done = 0  # done: input samples whose output was handed on
    step = max(
        1, min(block, READ_BYTES // (2 * channels))
    )  # frames per read (65,535 channels are no reason to read GBs)
    ended = False
    while not ended or done < buffer_start + len(buffer):
        while not ended and buffer_start + len(buffer) < done + block + margin:
            try:
                frames = wav.readframes(step)
            except (wave.Error, EOFError):  # a chunk header cut short: keep what came
                frames = b""
            frames = frames[
                : len(frames) - len(frames) % (2 * channels)
            ]  # cut mid-sample: keep what is whole
            if not frames:
                ended = True
                break
            mono = np.frombuffer(frames, dtype="<i2").reshape(-1, channels).mean(axis=1)
            buffer = np.concatenate([buffer, mono])
        total = buffer_start + len(buffer)
        if done >= total:
            break
        last = ended and total <= done + block
        if up == down:
            out = buffer[done - buffer_start : total if last else done + block]
        else:
            from scipy.signal import resample_poly

            begin = max(0, done - margin)
            window = buffer[begin - buffer_start : total if last else done + block + margin]
            resampled = resample_poly(window.astype(np.float32), up, down)
            skip = (done - begin) * up // down
            out = resampled[skip:] if last else resampled[skip : skip + block * up // down]
        yield bytes(np.clip(out, -32768, 32767).astype("<i2").tobytes())
        done = total if last else done + block
        keep_from = max(0, done - margin)
        buffer, buffer_start = buffer[keep_from - buffer_start :], keep_from


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
