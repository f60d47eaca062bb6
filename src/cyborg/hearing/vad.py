"""Cutting a stream of audio into utterances with Silero VAD (the ONNX model inside faster-whisper).

The model judges 32 ms frames; :class:`SileroUtterances` keeps its state from frame to frame
(faster-whisper's own helpers start afresh on each call, which suits whole files, not a
microphone), starts an utterance at the first frame it believes is speech (with a little audio
before it, so the first sound is not clipped) and ends it after ``silence`` seconds of frames
it believes are not. Same interface as pocketsphinx's :class:`~cyborg.hearing.recogniser.Utterances`.

It also says early when an utterance may be over (:attr:`SileroUtterances.tentative`: after
``early`` seconds of quiet), so that the ears can start decoding it while they wait to be sure;
an utterance that does end is cut where the tentative one was (its speech and ``early`` seconds
of quiet), so the early decode is the decode of the utterance itself.
"""

from __future__ import annotations

import importlib.util
from collections import deque
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from cyborg.hearing import HearingError
from cyborg.hearing.recogniser import SAMPLE_RATE

__all__ = ["SileroUtterances", "silero_model_path"]

FRAME = 512
"""Samples the model judges at a time (32 ms at 16 kHz)."""
CONTEXT = 64
"""Samples of the previous frame the model sees with each frame."""


def silero_model_path() -> Path:
    """The Silero VAD model shipped inside faster-whisper (found without importing the package)."""
    spec = importlib.util.find_spec("faster_whisper")
    folders = spec.submodule_search_locations if spec is not None else None
    path = Path(next(iter(folders))) / "assets" / "silero_vad_v6.onnx" if folders else None
    if path is None or not path.is_file():
        raise HearingError(
            "the Silero voice activity model is missing (faster-whisper is not installed); "
            "fix: run scripts/setup, or set vad: pocketsphinx"
        )
    return path


class SileroUtterances:
    """Cuts a stream of 16 kHz 16-bit audio into utterances where Silero VAD hears speech.

    ``feed(chunk)`` takes audio of any length and yields each utterance whose end it saw;
    ``finish()`` yields the one still open when the stream ends.
    """

    def __init__(
        self,
        *,
        threshold: float = 0.5,
        silence: float = 0.3,
        before: float = 0.2,
        min_speech: float = 0.1,
        early: float = 0.1,
        model: Path | None = None,
    ) -> None:
        try:
            import onnxruntime
        except ImportError as exc:
            raise HearingError(
                "onnxruntime is missing for Silero VAD; fix: run scripts/setup, or set vad: pocketsphinx"
            ) from exc
        options = onnxruntime.SessionOptions()
        options.inter_op_num_threads = 1
        options.intra_op_num_threads = 1
        options.log_severity_level = 4
        try:
            self._session: Any = onnxruntime.InferenceSession(
                str(model or silero_model_path()), providers=["CPUExecutionProvider"], sess_options=options
            )
        except Exception as exc:  # onnxruntime raises its own classes for a file that is no model
            raise HearingError(
                f"the Silero voice activity model cannot be loaded ({exc}); fix: reinstall faster-whisper "
                "(scripts/setup), or set vad: pocketsphinx"
            ) from exc
        self.threshold = threshold
        self._end_threshold = max(0.0, threshold - 0.15)
        self._silence_frames = max(1, round(silence * SAMPLE_RATE / FRAME))
        self._early_frames = min(self._silence_frames, max(1, round(early * SAMPLE_RATE / FRAME)))
        self.tentative: bytes | None = None
        """The open utterance as it would be cut if it ended now, once ``early`` seconds of quiet
        followed its speech; None while speech goes on or no utterance is open."""
        self._min_speech_frames = max(1, round(min_speech * SAMPLE_RATE / FRAME))
        self._before: deque[np.ndarray] = deque(maxlen=max(1, round(before * SAMPLE_RATE / FRAME)))
        self._pending = np.zeros(0, np.float32)
        self._reset_state()

    def _reset_state(self) -> None:
        self._state = np.zeros((1, 1, 128), np.float32), np.zeros((1, 1, 128), np.float32)
        self._context = np.zeros(CONTEXT, np.float32)
        self._speech: list[np.ndarray] = []
        self._speech_frames = 0
        self._quiet = 0
        self.tentative = None

    @property
    def in_speech(self) -> bool:
        """Whether an utterance is open."""
        return bool(self._speech)

    def probability(self, frame: np.ndarray) -> float:
        """The model's belief (0-1) that ``frame`` (:data:`FRAME` float samples) is speech."""
        batch = np.concatenate([self._context, frame])[None, :].astype(np.float32)
        h, c = self._state
        output, h, c = self._session.run(None, {"input": batch, "h": h, "c": c})
        self._state, self._context = (h, c), frame[-CONTEXT:]
        return float(np.asarray(output).reshape(-1)[0])

    def feed(self, chunk: bytes) -> Iterator[bytes]:
        """Yield the utterances that ended within ``chunk``."""
        samples = np.frombuffer(chunk, dtype="<i2").astype(np.float32) / 32768.0
        self._pending = np.concatenate([self._pending, samples])
        while len(self._pending) >= FRAME:
            frame, self._pending = self._pending[:FRAME], self._pending[FRAME:]
            speech = self.probability(frame)
            if not self._speech:
                if speech >= self.threshold:
                    self._speech = [*self._before, frame]
                    self._before.clear()
                    self._speech_frames, self._quiet = 1, 0
                else:
                    self._before.append(frame)
                continue
            self._speech.append(frame)
            if speech >= self._end_threshold:
                self._speech_frames += 1
                self._quiet = 0
                self.tentative = None
            else:
                self._quiet += 1
                if self._quiet == self._early_frames:
                    self.tentative = self._audio(self._speech) if self._enough() else None
                if self._quiet >= self._silence_frames:
                    cut = len(self._speech) - self._quiet + self._early_frames
                    utterance = self._take(cut)
                    if utterance is not None:
                        yield utterance

    def finish(self) -> Iterator[bytes]:
        """Yield the utterance still open at the end of the stream, if any; start afresh."""
        if len(self._pending):
            self._speech += [self._pending] if self._speech else []
        self._pending = np.zeros(0, np.float32)
        utterance = self._take() if self._speech else None
        self._before.clear()
        self._reset_state()
        if utterance is not None:
            yield utterance

    def _enough(self) -> bool:
        return self._speech_frames >= self._min_speech_frames

    def _take(self, frames: int | None = None) -> bytes | None:
        """The open utterance's audio (its first ``frames`` frames), or None if it held too little speech."""
        taken, enough = self._speech[:frames], self._enough()
        self._speech, self._speech_frames, self._quiet, self.tentative = [], 0, 0, None
        return self._audio(taken) if enough else None

    @staticmethod
    def _audio(frames: list[np.ndarray]) -> bytes:
        audio = np.concatenate(frames) * 32768.0
        return bytes(np.clip(audio, -32768, 32767).astype("<i2").tobytes())
