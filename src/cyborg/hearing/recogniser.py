"""Decoding speech with pocketsphinx's bundled US English model, and rejecting what is outside the grammar.

A grammar decoder maps any sound onto *some* sentence of the grammar, so the recogniser does
not decode against the grammar alone. It decodes against a small language model made from
the grammar's sentences (heavily weighted) and about a thousand common English words (the
most frequent ones of pocketsphinx's general model, weakly weighted, none that sounds like a
word of the grammar). Speech the robot understands comes out as a sentence of the grammar;
speech it does not understand comes out with common words in it, or as a fragment, and is
rejected and logged. The confidence is the decoder's posterior probability of the sentence
(its lattice); an utterance is believed when it is a whole sentence of the grammar and its
confidence is at least ``min_confidence``. :class:`Utterances` cuts a stream of audio into
utterances with pocketsphinx's own voice activity detection and end-pointing
(:class:`pocketsphinx.Endpointer`).
"""

from __future__ import annotations

import functools
import io
import logging
import math
import os
import re
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol

from cyborg.hearing.grammar import Grammar

__all__ = [
    "PLACE_DOUBT",
    "SAMPLE_RATE",
    "Heard",
    "Recogniser",
    "SpeechRecogniser",
    "Utterances",
    "known_word_of",
]

log = logging.getLogger(__name__)

SAMPLE_RATE = 16000
"""Samples per second of the audio the recogniser takes (16-bit mono)."""
DEFAULT_MIN_CONFIDENCE = 0.0
"""The whole-sentence test does the rejecting; a posterior threshold on top cost right sentences
more than it saved (docs/benchmarks-history.md, "Speech recognition")."""
PLACE_DOUBT = math.inf
"""Below this confidence (the sentence's posterior) a request that names a place is asked about
("Did you mean the cafeteria?") rather than believed. By default every one is: a grammar decoder
maps an unknown or misheard place onto the nearest sentence with a place, and its posteriors of
right and misheard places overlap (right 0.00-0.22, misheard up to 0.16 on the development sets,
issue 34's fourth round: docs/benchmarks-history.md)."""
BACKGROUND_WORDS = 1000
"""How many common English words compete with the grammar (the rejection's "anything else")."""
GRAMMAR_WEIGHT = 1000
"""How many times each grammar sentence counts against once for each common word."""
DISCOUNT_MASS = 0.02
"""Probability the language model leaves for word sequences it has not seen (fixed back-off)."""


@dataclass(frozen=True)
class Heard:
    """One decoded utterance: the text (place names as stored), its confidence 0-1, accepted or not."""

    text: str
    confidence: float
    accepted: bool
    raw: str
    """What the decoder heard, in the dictionary's words."""
    seconds: float
    """How long decoding took."""
    reason: str = ""
    """Why it was rejected ("" when accepted)."""
    ask: str | None = None
    """The place a request named when the ears are unsure of it (the text is then not accepted):
    a module may ask "Did you mean the <place>?" (``/cyborg_speech/unsure``)."""

    def as_json(self) -> dict[str, object]:
        """The record the dashboard shows."""
        return {
            "text": self.text,
            "confidence": round(self.confidence, 3),
            "accepted": self.accepted,
            "raw": self.raw,
            "reason": self.reason,
            "ask": self.ask,
        }

    def unsure_json(self) -> dict[str, object]:
        """The message of ``/cyborg_speech/unsure`` (only for a text with a place to ask about)."""
        return {
            "text": self.text,
            "place": self.ask,
            "confidence": round(self.confidence, 3),
            "reason": self.reason,
        }


def _model_paths() -> tuple[str, str, str]:
    from pocketsphinx import get_model_path

    base = os.path.join(get_model_path(), "en-us")
    return (
        os.path.join(base, "en-us"),
        os.path.join(base, "cmudict-en-us.dict"),
        os.path.join(base, "en-us.lm.bin"),
    )


@functools.cache
def pronunciations() -> dict[str, tuple[str, ...]]:
    """The bundled CMU dictionary: each word's pronunciations (phones separated by spaces)."""
    _, dictionary, _ = _model_paths()
    found: dict[str, list[str]] = {}
    with open(dictionary, encoding="utf-8") as lines:
        for line in lines:
            word, _, phones = line.strip().partition(" ")
            found.setdefault(word.split("(", 1)[0], []).append(phones.split("#", 1)[0].strip())
    return {word: tuple(phones) for word, phones in found.items()}


@functools.cache
def common_words(limit: int = 5 * BACKGROUND_WORDS) -> tuple[str, ...]:
    """The ``limit`` most frequent plain words of pocketsphinx's general English model, most frequent first."""
    from pocketsphinx import NGramModel

    _, _, general = _model_paths()
    model = NGramModel.readfile(general)
    scored = [(model.prob([word]), word) for word in pronunciations() if re.fullmatch(r"[a-z]+", word)]
    scored.sort(key=lambda pair: (-pair[0], pair[1]))
    return tuple(word for _, word in scored[:limit])


def known_word(word: str) -> bool:
    """Whether the bundled pronouncing dictionary has ``word``."""
    return word in pronunciations()


def known_word_of(decoder: Any) -> Callable[[str], bool]:
    """Whether the dictionary has a word (kept for callers that pass a decoder; it reads the bundled one)."""
    return known_word


def language_model_words(grammar: Grammar) -> list[str]:
    """The grammar's words, then the common English words that compete with them.

    A common word that sounds like a grammar word ("know" for "no") is left out, or the
    grammar's word would lose to it half the time.
    """
    said = pronunciations()
    vocabulary = sorted({word for sentence in grammar.sentences() for word in sentence.split()})
    sounds = {phones for word in vocabulary for phones in said.get(word, ())}
    background = [
        w for w in common_words() if w not in vocabulary and not sounds.intersection(said.get(w, ()))
    ]
    return vocabulary + background[:BACKGROUND_WORDS]


def language_model_text(grammar: Grammar, words: list[str]) -> str:
    """The ARPA language model of ``grammar``'s sentences against the other ``words``."""
    from pocketsphinx.lm import ArpaBoLM

    model = ArpaBoLM(text="\n".join(grammar.sentences()), add_start=True, discount_mass=DISCOUNT_MASS)
    tables: list[dict[str, int]] = [model.grams_1, *model.grams_2.values()]
    tables += [counts for follows in model.grams_3.values() for counts in follows.values()]
    for counts in tables:  # each grammar sentence counts GRAMMAR_WEIGHT times, each other word once
        for word in counts:
            counts[word] *= GRAMMAR_WEIGHT
    for word in words:
        model.grams_1.setdefault(word, 1)
    model.compute()
    out = io.StringIO()
    model.write(out)
    return out.getvalue()


class SpeechRecogniser(Protocol):
    """What the ears decode with: pocketsphinx (:class:`Recogniser`) or Whisper
    (:class:`~cyborg.hearing.whisper.WhisperRecogniser`)."""

    name: str
    grammar: Grammar | None
    min_confidence: float

    def known_word(self, word: str) -> bool:
        """Whether the recogniser can hear ``word`` (phrases with other words are left out)."""
        ...

    def use(self, grammar: Grammar) -> None:
        """Listen for ``grammar`` from the next utterance on."""
        ...

    def decode(self, audio: bytes) -> Heard:
        """Decode one utterance (16-bit little-endian mono samples at :data:`SAMPLE_RATE`)."""
        ...


class Recogniser:
    """Decodes 16 kHz 16-bit mono utterances against a grammar and says whether to believe them."""

    name = "pocketsphinx"

    def __init__(
        self, *, min_confidence: float = DEFAULT_MIN_CONFIDENCE, place_doubt: float = PLACE_DOUBT
    ) -> None:
        self.min_confidence = min_confidence
        self.place_doubt = place_doubt
        """A request naming a place heard at a lower confidence is asked about, not believed (:data:`PLACE_DOUBT`)."""
        self.known_word = known_word
        self.grammar: Grammar | None = None
        self._decoder: Any = None

    def use(self, grammar: Grammar) -> None:
        """Listen for ``grammar`` from the next utterance on (builds a new decoder; a decode under way
        finishes with the old one)."""
        from pocketsphinx import Decoder

        hmm, _, _ = _model_paths()
        words = language_model_words(grammar)
        said = pronunciations()
        entries = [
            f"{word}{f'({i + 1})' if i else ''} {phones}"
            for word in words
            for i, phones in enumerate(said.get(word, ()))
        ]
        with tempfile.TemporaryDirectory() as folder:
            dictionary, model = os.path.join(folder, "robot.dict"), os.path.join(folder, "robot.arpa")
            with open(dictionary, "w", encoding="utf-8") as out:
                out.write("\n".join(entries) + "\n")
            with open(model, "w", encoding="utf-8") as out:
                out.write(language_model_text(grammar, words))
            decoder = Decoder(hmm=hmm, dict=dictionary, lm=model, loglevel="FATAL", samprate=SAMPLE_RATE)
        self._decoder, self.grammar = decoder, grammar

    def decode(self, audio: bytes) -> Heard:
        """Decode one utterance (16-bit little-endian mono samples at :data:`SAMPLE_RATE`)."""
        grammar, decoder = self.grammar, self._decoder
        if grammar is None:
            from cyborg.hearing import HearingError

            raise HearingError("the recogniser has no grammar yet; fix: call use(grammar) first")
        started = time.perf_counter()
        decoder.start_utt()
        decoder.process_raw(audio, full_utt=True)
        decoder.end_utt()
        hypothesis = decoder.hyp()
        raw = hypothesis.hypstr if hypothesis is not None else ""
        confidence = min(1.0, max(0.0, float(hypothesis.prob))) if hypothesis is not None and raw else 0.0
        if not raw:
            reason = "nothing heard"
        elif not grammar.holds(raw):
            reason = "not a sentence the robot understands"
        elif confidence < self.min_confidence:
            reason = f"confidence {confidence:.2f} < {self.min_confidence:.2f}"
        else:
            reason = ""
        text = grammar.canonical(raw) if raw else ""
        ask = None
        if not reason and confidence < self.place_doubt and (place := _place_in(raw, grammar)):
            reason, ask = f"unsure of the place: {place} at confidence {confidence:.2f}", place
        heard = Heard(text, confidence, not reason, raw, time.perf_counter() - started, reason, ask)
        if reason:
            log.info("rejected speech %r (confidence %.2f): %s", raw, confidence, reason)
        return heard


def _place_in(raw: str, grammar: Grammar) -> str | None:
    """The place a sentence of ``grammar`` names (its longest spoken form in ``raw``), or None."""
    said = f" {raw} "
    forms = [form for form in grammar.place_forms if f" {form} " in said]
    return grammar.place_forms[max(forms, key=len)] if forms else None


class Utterances:
    """Cuts a stream of 16 kHz audio into utterances (pocketsphinx's voice activity detection).

    ``feed(chunk)`` takes audio of any length and yields each utterance whose end it saw;
    ``finish()`` yields the one still open when the stream ends.
    """

    def __init__(self, *, window: float = 0.3, ratio: float = 0.9, vad_mode: int = 2) -> None:
        from pocketsphinx import Endpointer

        self._endpointer = Endpointer(window=window, ratio=ratio, vad_mode=vad_mode, sample_rate=SAMPLE_RATE)
        self._pending = b""
        self._offset = 0  # of the first byte of _pending not yet judged
        self._speech: list[bytes] = []

    @property
    def frame_bytes(self) -> int:
        """Bytes of one frame the endpointer judges."""
        return int(self._endpointer.frame_bytes)

    def feed(self, chunk: bytes) -> Iterator[bytes]:
        """Yield the utterances that ended within ``chunk``."""
        self._pending = self._pending[self._offset :] + chunk  # one copy per chunk, not one per frame
        self._offset = 0
        size = self.frame_bytes
        while len(self._pending) - self._offset >= size:
            frame = self._pending[self._offset : self._offset + size]
            self._offset += size
            speech = self._endpointer.process(frame)
            if speech is not None:
                self._speech.append(speech)
                if not self._endpointer.in_speech:
                    yield self._take()

    def finish(self) -> Iterator[bytes]:
        """Yield the utterance still open at the end of the stream, if any."""
        if self._endpointer.in_speech:
            tail = self._pending[self._offset :]
            rest = self._endpointer.end_stream((tail + bytes(self.frame_bytes))[: self.frame_bytes])
            if rest is not None:
                self._speech.append(rest)
        self._pending = b""
        self._offset = 0
        if self._speech:
            yield self._take()

    def _take(self) -> bytes:
        utterance, self._speech = b"".join(self._speech), []
        return utterance
