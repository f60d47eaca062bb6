"""Decoding speech with pocketsphinx's bundled US English model, and rejecting what is outside the grammar.

A grammar decoder maps any sound onto *some* sentence of the grammar, so each utterance is
also decoded by a phone loop (pocketsphinx's ``allphone`` search: the phones heard, with no
words). The phones of the grammar's sentence are compared with the phones heard; the
confidence is one minus their normalised edit distance. An utterance whose confidence is
below ``min_confidence`` is rejected and logged with its score. :class:`Utterances` cuts a
stream of audio into utterances with pocketsphinx's own voice activity detection and
end-pointing (:class:`pocketsphinx.Endpointer`).
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from rapidfuzz.distance import Levenshtein

from cyborg.hearing.grammar import Grammar

__all__ = ["SAMPLE_RATE", "Heard", "Recogniser", "Utterances", "known_word_of"]

log = logging.getLogger(__name__)

SAMPLE_RATE = 16000
"""Samples per second of the audio the recogniser takes (16-bit mono)."""
DEFAULT_MIN_CONFIDENCE = 0.3


@dataclass(frozen=True)
class Heard:
    """One decoded utterance: the text (place names as stored), its confidence 0-1, accepted or not."""

    text: str
    confidence: float
    accepted: bool
    raw: str
    """What the grammar decoder heard, in the dictionary's words."""
    phones: str
    """What the phone loop heard."""
    seconds: float
    """How long decoding took."""

    def as_json(self) -> dict[str, object]:
        """The record the dashboard shows."""
        return {
            "text": self.text,
            "confidence": round(self.confidence, 3),
            "accepted": self.accepted,
            "raw": self.raw,
        }


def _model_paths() -> tuple[str, str, str]:
    from pocketsphinx import get_model_path

    base = os.path.join(get_model_path(), "en-us")
    return (
        os.path.join(base, "en-us"),
        os.path.join(base, "cmudict-en-us.dict"),
        os.path.join(base, "en-us-phone.lm.bin"),
    )


def known_word_of(decoder: Any) -> Any:
    """A check whether the decoder's pronouncing dictionary has a word."""

    def known(word: str) -> bool:
        try:
            return decoder.lookup_word(word) is not None
        except (KeyError, RuntimeError):
            return False

    return known


class Recogniser:
    """Decodes 16 kHz 16-bit mono utterances against a grammar and says whether to believe them."""

    def __init__(self, *, min_confidence: float = DEFAULT_MIN_CONFIDENCE) -> None:
        from pocketsphinx import Decoder

        hmm, dictionary, phone_lm = _model_paths()
        self.min_confidence = min_confidence
        self._words = Decoder(hmm=hmm, dict=dictionary, loglevel="FATAL", samprate=SAMPLE_RATE)
        self._phones = Decoder(hmm=hmm, allphone=phone_lm, loglevel="FATAL", samprate=SAMPLE_RATE)
        self.known_word = known_word_of(self._words)
        self.grammar: Grammar | None = None

    def use(self, grammar: Grammar) -> None:
        """Listen for ``grammar`` from the next utterance on."""
        self._words.add_jsgf_string("robot", grammar.jsgf)
        self._words.activate_search("robot")
        self.grammar = grammar

    def _decode(self, decoder: Any, audio: bytes) -> str:
        decoder.start_utt()
        decoder.process_raw(audio, full_utt=True)
        decoder.end_utt()
        hypothesis = decoder.hyp()
        return hypothesis.hypstr if hypothesis is not None else ""

    def _phones_of(self, words: str) -> list[str]:
        out: list[str] = []
        for word in words.split():
            out += (self._words.lookup_word(word) or "").split()
        return out

    def decode(self, audio: bytes) -> Heard:
        """Decode one utterance (16-bit little-endian mono samples at :data:`SAMPLE_RATE`)."""
        if self.grammar is None:
            from cyborg.hearing import HearingError

            raise HearingError("the recogniser has no grammar yet; fix: call use(grammar) first")
        started = time.perf_counter()
        raw = self._decode(self._words, audio)
        heard_phones = [p for p in self._decode(self._phones, audio).split() if p != "SIL"]
        confidence = 1.0 - Levenshtein.normalized_distance(self._phones_of(raw), heard_phones) if raw else 0.0
        accepted = bool(raw) and confidence >= self.min_confidence
        text = self.grammar.canonical(raw) if raw else ""
        heard = Heard(text, confidence, accepted, raw, " ".join(heard_phones), time.perf_counter() - started)
        if not accepted:
            log.info("rejected speech %r (confidence %.2f < %.2f)", raw, confidence, self.min_confidence)
        return heard


class Utterances:
    """Cuts a stream of 16 kHz audio into utterances (pocketsphinx's voice activity detection).

    ``feed(chunk)`` takes audio of any length and yields each utterance whose end it saw;
    ``finish()`` yields the one still open when the stream ends.
    """

    def __init__(self, *, window: float = 0.3, ratio: float = 0.9, vad_mode: int = 2) -> None:
        from pocketsphinx import Endpointer

        self._endpointer = Endpointer(window=window, ratio=ratio, vad_mode=vad_mode, sample_rate=SAMPLE_RATE)
        self._pending = b""
        self._speech: list[bytes] = []

    @property
    def frame_bytes(self) -> int:
        """Bytes of one frame the endpointer judges."""
        return int(self._endpointer.frame_bytes)

    def feed(self, chunk: bytes) -> Iterator[bytes]:
        """Yield the utterances that ended within ``chunk``."""
        self._pending += chunk
        size = self.frame_bytes
        while len(self._pending) >= size:
            frame, self._pending = self._pending[:size], self._pending[size:]
            speech = self._endpointer.process(frame)
            if speech is not None:
                self._speech.append(speech)
                if not self._endpointer.in_speech:
                    yield self._take()

    def finish(self) -> Iterator[bytes]:
        """Yield the utterance still open at the end of the stream, if any."""
        if self._endpointer.in_speech:
            rest = self._endpointer.end_stream((self._pending + bytes(self.frame_bytes))[: self.frame_bytes])
            if rest is not None:
                self._speech.append(rest)
        self._pending = b""
        if self._speech:
            yield self._take()

    def _take(self) -> bytes:
        utterance, self._speech = b"".join(self._speech), []
        return utterance
