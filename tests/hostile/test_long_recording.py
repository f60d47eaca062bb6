"""Review 12.8: `cyborg listen --wav` of an hour's recording held the whole hour in memory several
times over (1.3 GB peak for a 115 MB file: read, mixed down in float64, noise added in float64),
so a day's recording could not be heard on the robot's computer. It now reads, converts and
hears it a few seconds at a time: what it holds does not grow with the recording's length.
"""

from __future__ import annotations

import math
import tracemalloc
import wave
from pathlib import Path

import numpy as np
from scipy.signal import resample_poly

from cyborg.hearing.audio import wav_chunks
from cyborg.hearing.synth import as_heard_chunks


def _recording(path: Path, minutes: float, rate: int = 22_050, channels: int = 1) -> Path:
    """A recording of ``minutes``: one second of a tone in noise, over and over."""
    rng = np.random.default_rng(1)
    second = 3000 * np.sin(2 * np.pi * 440 * np.arange(rate) / rate) + rng.normal(0, 500, rate)
    frames = np.repeat(second[:, None], channels, axis=1).astype("<i2").tobytes()
    with wave.open(str(path), "wb") as wav:
        wav.setnchannels(channels)
        wav.setsampwidth(2)
        wav.setframerate(rate)
        for _ in range(round(minutes * 60)):
            wav.writeframes(frames)
    return path


def _peak_while_heard(path: Path) -> int:
    """Peak bytes allocated while the recording goes to the recogniser as `cyborg listen` sends it."""
    tracemalloc.start()
    try:
        samples = sum(len(chunk) for chunk in as_heard_chunks(wav_chunks(path), noise=10.0, pad=0.5))
        assert samples > 0
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_hearing_a_long_recording_holds_seconds_of_it_not_the_whole(tmp_path: Path) -> None:
    short = _recording(tmp_path / "one_minute.wav", 1, rate=16_000)
    long = _recording(tmp_path / "eight_minutes.wav", 8, rate=16_000)  # 15 MB
    short_peak, long_peak = _peak_while_heard(short), _peak_while_heard(long)
    assert long_peak < 1.5 * short_peak, (  # the old way: 51 MB for 2 minutes, 408 MB for 16
        f"hearing 8 times as much took {long_peak / short_peak:.1f} times the memory "
        f"({short_peak / 1e6:.1f} MB for 1 minute, {long_peak / 1e6:.1f} MB for 8)"
    )
    assert long_peak < long.stat().st_size / 2, f"{long_peak / 1e6:.1f} MB held for a 15 MB recording"


def test_a_recording_read_in_chunks_is_what_resampling_it_whole_gives(tmp_path: Path) -> None:
    """The chunks join without a seam: 44.1 kHz stereo, read 2 s at a time, equals the whole at 16 kHz."""
    path = _recording(tmp_path / "stereo.wav", 0.4, rate=44_100, channels=2)
    with wave.open(str(path)) as wav:
        whole = np.frombuffer(wav.readframes(wav.getnframes()), dtype="<i2").reshape(-1, 2).mean(axis=1)
    common = math.gcd(44_100, 16_000)
    expected = np.clip(
        resample_poly(whole.astype(np.float32), 16_000 // common, 44_100 // common), -32768, 32767
    )
    chunks = list(wav_chunks(path, seconds=2.0))
    assert len(chunks) == 12
    joined = np.frombuffer(b"".join(chunks), dtype="<i2")
    assert len(joined) == len(expected)
    assert np.array_equal(joined, expected.astype("<i2"))
