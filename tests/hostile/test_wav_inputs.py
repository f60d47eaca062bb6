"""Issue 31, item 6: recordings as a killed recorder leaves them are heard, not a traceback.

Review 12.4: a 16-bit WAV cut mid-sample (an odd number of data bytes) ended `cyborg listen
--wav` in "ValueError: buffer size must be a multiple of element size". (Broken sample rates
are in cases.yaml: they are refused as real commands.)
"""

from __future__ import annotations

import io
import wave
from pathlib import Path

from cyborg.hearing.audio import read_wav, wav_bytes

FILES = Path(__file__).parent / "files"


def test_a_recording_cut_mid_sample_keeps_its_whole_samples() -> None:
    audio = read_wav(FILES / "_wav_cut_mid_sample.wav")
    assert len(audio) == 2 * 1599  # the file holds 1,599 whole samples and half of one more


def test_a_stereo_recording_cut_mid_frame_keeps_its_whole_frames() -> None:
    data = io.BytesIO()
    with wave.open(data, "wb") as wav:
        wav.setnchannels(2)
        wav.setsampwidth(2)
        wav.setframerate(16_000)
        wav.writeframes(bytes(4 * 800))
    cut = data.getvalue()[:-3]
    assert len(wav_bytes(cut)) == 2 * 799
