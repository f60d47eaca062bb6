"""Keyword detection in speech-to-text: navigation requests, questions and yes/no answers.

Part of the navigation module's pure logic layer (no I/O). The module listens to
the text the STT publishes and turns it into one of a few intents: a command to
go somewhere ("go to" / "move to"), a question where a place is ("where is"), a
request for the robot's opinion of a place ("think of") or a yes/no answer, each in the many
ways people say it ("can you point me to", "I need to find", "how can I reach"). The phrasings
are content, in ``navigation/data/phrasings.yaml`` (read and checked once, at import).

Place names are matched tolerantly with rapidfuzz, because STT mishears: small
typos ("cafetria"), split or joined words ("el 6", "entrance2") and numbers spoken
as words ("entrance two") still match, while unrelated words do not (a score
threshold, and digits in a name must match exactly, so "el5" never matches "el6"). A place
heard only roughly is a match that is not :attr:`~Detection.certain`: the robot asks first.
"""

from __future__ import annotations

import enum
import itertools
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path

import snowballstemmer
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from rapidfuzz import fuzz

from cyborg.configfile import describe_errors, load_yaml, read_text_file
from cyborg.errors import ConfigError, NavigationError

DEFAULT_THRESHOLD = 80.0
"""Lowest rapidfuzz ratio (0-100) at which a span of text counts as a place name."""
CERTAIN_SCORE = 90.0
"""Lowest ratio at which the robot acts on a place without asking "Did you mean ...?" first."""
CODE_THRESHOLD = 60.0
"""Lowest ratio at which a short code heard with other letters but the same digits ("a16" for
"e16") is a (never certain) candidate."""
ANSWER_START = 1
"""An answer's first word comes at most this many words into a longer sentence ("well, yes")."""
SHORT_ANSWER = 4
"""A sentence of at most this many words may hold its answer anywhere ("I guess so, yes")."""

NUMBER_WORDS: dict[str, str] = {
    word: str(n)
    for n, word in enumerate(
        [
            "zero",
            "one",
            "two",
            "three",
            "four",
            "five",
            "six",
            "seven",
            "eight",
            "nine",
            "ten",
            "eleven",
            "twelve",
            "thirteen",
            "fourteen",
            "fifteen",
            "sixteen",
            "seventeen",
            "eighteen",
            "nineteen",
            "twenty",
        ]
    )
}

NUMBER_SOUNDS = {"to": "2", "too": "2", "for": "4", "won": "1", "ate": "8"}
"""Words speech-to-text writes for a number at the end of a place's name ("entrance to")."""

TRAILING_WORDS = frozenset({"please", "now", "thanks", "thank", "you"})
"""Polite words people put after a place ("go to the entrance 2 please")."""

SUFFIX_WORDS = frozenset(
    {*"bcdefghijklmnopqrstuvwxyz", "ii", "iii", "iv", "vi", "vii", "viii", "ix", "xi", "xii"}
)
"""Words that, last in a sentence right after a place's name, may be the rest of another place's
name ("where is the entrance i" for "entrance 5", "room b"): the place is asked about first.
Not "a", which ends sentences in its own right."""

CLOSING_WORDS = frozenset(
    {
        "located",
        "situated",
        "again",
        "here",
        "there",
        "then",
        "today",
        "too",
        "first",
        "quickly",
        "ok",
        "okay",
    }
)
"""Words that end a request right after a place's name ("where is the cafeteria located"). Any
other word there may be the rest of another place's name ("where is the lift shop", the gift
shop misheard): the place is asked about first."""

FILLER_WORDS = frozenset({"the", "a", "an", "my", "this", "that", "to", "at", "of", "is"})
"""Words a place-name match may not start or end with (unless the name itself does)."""


class Intent(enum.Enum):
    """What a sentence asks of the robot; the navigation values are the controller's event names."""

    NAVIGATION_COMMAND = "navigation_command"
    NAVIGATION_INFORMATION = "navigation_information"
    NAVIGATION_FEEDBACK = "navigation_feedback"
    YES = "yes"
    NO = "no"


DETERMINERS = frozenset({"the", "a", "an", "my", "this", "that"})
"""Words a trigger phrase's own determiner may be heard as ("show me that way to")."""

NUMBER_LEADS = frozenset({"number", "nr"})
"""Words before a number that say only that a number comes ("entrance number 2" is entrance 2)."""


def normalise(text: str) -> str:
    """Lower-case, drop punctuation and apostrophes, spell numbers as digits, single spaces; "number"
    before a number is left out.

    >>> normalise("Where's  Entrance-Two?")
    'wheres entrance 2'
    >>> normalise("where is entrance number two")
    'where is entrance 2'
    """
    text = text.casefold().replace("'", "").replace("\u2019", "")
    kept: list[str] = []
    for word in reversed(re.sub(r"[\W_]+", " ", text).split()):  # from the end: "number number 2" is 2
        if not (word in NUMBER_LEADS and kept and kept[-1].isdigit()):
            kept.append(NUMBER_WORDS.get(word, word))
    return " ".join(reversed(kept))


PHRASINGS_FILE = Path(str(resources.files("cyborg") / "navigation" / "data" / "phrasings.yaml"))
"""How people ask for a place and answer the robot's questions: content, edited there."""
_NAVIGATION = (Intent.NAVIGATION_COMMAND, Intent.NAVIGATION_INFORMATION, Intent.NAVIGATION_FEEDBACK)


class _PhrasingsFile(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)

    requests: dict[str, list[str]]
    cue_words: dict[str, list[str]] = Field(default_factory=dict)
    statement_words: list[str] = Field(default_factory=list)
    yes_answers: list[str]
    no_answers: list[str]
    plain: list[str] = Field(default_factory=list)


@dataclass(frozen=True)
class Phrasings:
    """The phrasings of ``phrasings.yaml``, checked."""

    requests: dict[Intent, tuple[str, ...]]
    cue_words: dict[Intent, tuple[str, ...]]
    statement_words: tuple[str, ...]
    yes_answers: tuple[str, ...]
    no_answers: tuple[str, ...]
    plain: tuple[str, ...]


def load_phrasings(path: Path = PHRASINGS_FILE) -> Phrasings:
    """Read and check a phrasings file; a broken one raises :class:`~cyborg.errors.ConfigError`
    naming the entry and the fix."""
    try:
        data = load_yaml(read_text_file(path), str(path))
        raw = _PhrasingsFile.model_validate(data)
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read it ({exc}); fix: reinstall cyborg", source=str(path)) from exc
    except ValidationError as exc:
        raise ConfigError(
            describe_errors(exc, _PhrasingsFile, where="", doc="the comment at the top of the shipped file"),
            source=str(path),
        ) from exc
    kinds = ", ".join(i.value for i in _NAVIGATION)
    problems: list[str] = []

    def by_intent(section: str, rows: dict[str, list[str]]) -> dict[Intent, tuple[str, ...]]:
        found: dict[Intent, tuple[str, ...]] = {}
        for key, phrases in rows.items():
            intent = next((i for i in _NAVIGATION if i.value == key), None)
            if intent is None:
                problems.append(f"{section}.{key}: no such request; fix: use one of {kinds}")
                continue
            found[intent] = tuple(phrases)
        return found

    requests = by_intent("requests", raw.requests)
    cue_words = by_intent("cue_words", raw.cue_words)
    sections = {
        **{f"requests.{i.value}": p for i, p in requests.items()},
        **{f"cue_words.{i.value}": p for i, p in cue_words.items()},
        "statement_words": tuple(raw.statement_words),
        "yes_answers": tuple(raw.yes_answers),
        "no_answers": tuple(raw.no_answers),
        "plain": tuple(raw.plain),
    }
    for section, phrases in sections.items():
        for phrase in phrases:
            if normalise(phrase) != phrase or not phrase:
                problems.append(
                    f"{section}: {phrase!r} is not as the robot reads speech; fix: write {normalise(phrase)!r}"
                )
    known = {p for section, ps in sections.items() if section not in ("plain", "statement_words") for p in ps}
    problems += [
        f"plain: {p!r} is no request or answer of the file; fix: add it to one, or leave it out"
        for p in raw.plain
        if p not in known
    ]
    if problems:
        raise ConfigError(problems, source=str(path))
    return Phrasings(
        {i: requests.get(i, ()) for i in _NAVIGATION},
        cue_words,
        tuple(raw.statement_words),
        tuple(raw.yes_answers),
        tuple(raw.no_answers),
        tuple(raw.plain),
    )


_PHRASINGS = load_phrasings()

TRIGGERS: dict[Intent, tuple[str, ...]] = _PHRASINGS.requests
"""Phrases (normalised; ``phrasings.yaml``) that start a navigation request; the place must come after them.

The ways people ask, beyond the thesis's "go to", "where is" and "think of": a request to be
taken somewhere is a command, a question about the way is a request for information."""

ALL_TRIGGERS: tuple[str, ...] = tuple(
    dict.fromkeys(
        phrase for row in itertools.zip_longest(*TRIGGERS.values()) for phrase in row if phrase is not None
    )
)
"""Every trigger, the intents taking turns, the most common phrasings first."""

PLAIN_PHRASES = frozenset(_PHRASINGS.plain)
"""The requests and answers of the thesis and a few more: what a recogniser that can only hear
whole sentences of a grammar (pocketsphinx) listens for; the many other phrasings cost it more in
confusions than they gain (docs/benchmarks-history.md, issue 34)."""

WEAK_ANSWERS = frozenset({"please", "right"})
"""Answers only when said (nearly) alone: "please" is yes, "turn around please" is not."""
ENDING_ANSWERS = frozenset({"lets go"})
"""Answers only at the end of a sentence (or before companions): "yes, let's go" is yes, "let's
go dancing" is none."""
LEADING_NO = frozenset({"no", "nope", "nah"})
"""A sentence that starts with one of these is a no even when yes-words follow ("no, that's okay")."""
WEAK_NO_ANSWERS = frozenset({"never", "dont", "do not"})
"""Answers only in a short sentence ("never!", "please don't"): "I do not like him at home" is none."""
WEAK_NO_WORDS = 3
"""The most words a sentence with a weak no-answer may have."""
ANSWER_COMPANIONS = frozenset(
    {"then", "thanks", "thank", "you", "robot", "cyborg", "yes", "sure", "ok", "okay"}
)
"""Words that may stand beside a weak answer ("please, thank you")."""

NEGATIONS = frozenset({"dont", "not", "never", "cant", "wont", "shouldnt", "stop"})
"""Words that turn a command round ("don't go to the cafeteria"): a command right after one is no command."""

YES_PHRASES: tuple[str, ...] = _PHRASINGS.yes_answers
"""Answers that say yes (``phrasings.yaml``)."""
NO_PHRASES: tuple[str, ...] = _PHRASINGS.no_answers
"""Answers that say no (``phrasings.yaml``)."""


@dataclass(frozen=True)
class LocationMatch:
    """A place name found in text: the stored name, the words that matched and the score (0-100)."""

    location: str
    matched: str
    score: float
    start: int
    """Index of the first matched word in the normalised text."""

    @property
    def certain(self) -> bool:
        """Whether the words are the place's name or close enough that asking would be silly."""
        return self.score >= CERTAIN_SCORE


@dataclass(frozen=True)
class Detection:
    """The intent of one sentence; ``location`` is the stored name (None for yes/no)."""

    intent: Intent
    location: str | None
    matched: str
    score: float

    @property
    def certain(self) -> bool:
        """False when the place was heard only roughly ("where is the a16" for the e16): ask first."""
        return self.score >= CERTAIN_SCORE


def _compact(words: Sequence[str]) -> str:
    return "".join(words)


def _digits(text: str) -> str:
    return "".join(re.findall(r"\d+", text))


@dataclass(frozen=True)
class _Spoken:
    location: str
    words: tuple[str, ...]
    compact: str
    digits: str


class LocationMatcher:
    """Finds known place names (or their aliases) in normalised text, tolerating STT errors."""

    def __init__(
        self, places: Iterable[tuple[str, Iterable[str]]], threshold: float = DEFAULT_THRESHOLD
    ) -> None:
        """``places`` is (stored name, aliases) pairs; ``threshold`` the lowest ratio that matches."""
        if not 0 < threshold <= 100:
            raise NavigationError(f"threshold={threshold} is outside (0, 100]; use e.g. {DEFAULT_THRESHOLD}")
        self.threshold = threshold
        self._spoken: list[_Spoken] = []
        for name, aliases in places:
            for form in (name, *aliases):
                words = tuple(normalise(form).split())
                if words:
                    compact = _compact(words)
                    self._spoken.append(_Spoken(name, words, compact, _digits(compact)))

    @property
    def names(self) -> list[str]:
        """The stored names this matcher knows, in order, without duplicates."""
        return list(dict.fromkeys(s.location for s in self._spoken))

    def find(self, text: str) -> LocationMatch | None:
        """The best place name in ``text`` (earliest; then highest score; then longest), or None.

        A sentence that ends in a word that sounds like a number ("where is the entrance to",
        speech-to-text's "entrance 2"; polite words after it count as its end: "entrance to
        please") is also read with the number; a place found only that way is not certain, and
        neither is the place without the number. Nor is a place followed, last, by one more word
        that is not part of its name, unless it is a word that ends such requests
        (:data:`CLOSING_WORDS`): it may be another place's name misheard ("entrance i" for
        entrance 5, "the lift shop" for the gift shop).
        """
        words = normalise(text).split()
        found = self._find(words)
        end = len(words)
        while end > 1 and words[end - 1] in TRAILING_WORDS:
            end -= 1
        if end and words[end - 1] in NUMBER_SOUNDS:
            with_number = self._find([*words[: end - 1], NUMBER_SOUNDS[words[end - 1]]])
            if with_number is not None and (found is None or with_number.location != found.location):
                return replace(with_number, score=min(with_number.score, CERTAIN_SCORE - 1))
        if found is not None and found.start + len(found.matched.split()) == end - 1:
            suffix = words[end - 1]
            unknown = suffix not in CLOSING_WORDS and not suffix.isdigit()
            if (suffix in SUFFIX_WORDS or unknown) and not normalise(found.matched).endswith(f" {suffix}"):
                return replace(found, score=min(found.score, CERTAIN_SCORE - 1))
        return found

    def _find(self, words: list[str]) -> LocationMatch | None:
        best: tuple[int, float, int] | None = None
        found: LocationMatch | None = None
        for spoken in self._spoken:
            for match in self._matches(spoken, words):
                key = (-match.start, match.score, len(spoken.compact))
                if best is None or key > best:
                    best, found = key, match
        return found

    def _matches(self, spoken: _Spoken, words: list[str]) -> Iterable[LocationMatch]:
        n = len(spoken.words)
        for size in range(max(1, n - 1), n + 3):
            for start in range(len(words) - size + 1):
                window = words[start : start + size]
                if not self._plausible(spoken, window, words, start + size):
                    continue
                heard = _compact(window)
                score = fuzz.ratio(heard, spoken.compact)
                if score >= self.threshold or (
                    spoken.digits and score >= CODE_THRESHOLD and _same_code(heard, spoken.compact)
                ):
                    yield LocationMatch(spoken.location, " ".join(window), score, start)

    @staticmethod
    def _plausible(spoken: _Spoken, window: list[str], words: list[str], end: int) -> bool:
        """Cheap rules that reject spans before scoring: fillers at the edges, digits that differ."""
        if window[0] in FILLER_WORDS and window[0] != spoken.words[0]:
            return False
        if window[-1] in FILLER_WORDS and window[-1] != spoken.words[-1]:
            return False
        if _digits(_compact(window)) != spoken.digits:
            return False
        # "entrance 3" is not "entrance": a number right after the span belongs to the name.
        return not (end < len(words) and words[end].isdigit() and not spoken.digits)


def _same_code(heard: str, name: str) -> bool:
    """``"a16"`` and ``"e16"``: a short name of letters and digits, heard with other letters, same digits."""
    return len(heard) <= 4 and bool(re.fullmatch(r"[a-z]{1,2}\d+", heard)) and heard[-2:] == name[-2:]


def _find_phrase(words: list[str], phrase: str) -> int | None:
    """Index just after the first occurrence of ``phrase`` (normalised words) in ``words``; one other
    word may stand between two of its words ("where exactly is", "drive over to"), and another
    determiner for one of its own ("show me that way to", "show me my way to")."""
    target = phrase.split()
    for i in range(len(words) - len(target) + 1):
        if words[i] != target[0]:
            continue
        at = i + 1
        for word in target[1:]:
            if at < len(words) and (words[at] == word or (word in DETERMINERS and words[at] in DETERMINERS)):
                at += 1
            elif at + 1 < len(words) and words[at + 1] == word and words[at] not in FILLER_WORDS:
                at += 2
            else:
                break
        else:
            return at
    return None


def _negated(words: list[str], start: int) -> bool:
    """Whether a negation comes just before the phrase starting at ``start`` ("do not go to")."""
    return any(w in NEGATIONS for w in words[max(0, start - 3) : start])


CUE_STOP_WORDS = frozenset(
    {
        *FILLER_WORDS,
        *("i", "me", "you", "your", "we", "us", "do", "can", "could", "would", "will", "might"),
        *("how", "there", "on", "about", "over", "are", "for", "with", "in", "into", "towards"),
        *("want", "need", "help", "know", "tell", "trying", "cant", "lets"),
    }
)
"""Words of the trigger phrases that say nothing of what is asked on their own (function words,
and verbs that lean on the trigger's other words: "need to find", "tell me where")."""
CUE_SCORE = 0.6
"""Lowest score (the sum of the cue words' shares) at which a sentence without a trigger phrase
is read as a request of the intent its cue words lean to."""
STATEMENT_OPENERS = frozenset(
    {"my", "his", "her", "their", "our", "the", "this", "that", "he", "she", "they", "it", "its"}
)
"""First words of a sentence about something rather than a request ("my friend is looking at the
lift", "the lift smells funny"): without a trigger phrase, no request."""
STATEMENT_WORDS = frozenset(_PHRASINGS.statement_words)
"""Words (``phrasings.yaml``) that make a sentence without a trigger phrase a statement about the
past ("i saw you near the cafeteria"): no request."""
SUBJECT_VERBS = frozenset({"is", "was", "has", "had", "isnt", "wasnt"})
"""Words after a place that opens a sentence which make it a statement about the place ("el6 is
where i work"), not a request."""
FUZZY_TRIGGER_SCORE = 85.0
"""Lowest rapidfuzz ratio at which the words before a place count as a misheard trigger phrase
("show me the wait on" for "show me the way to")."""
ME_TO = ("me to", "us to", "with me to", "with us to", "me over to", "us over to")
"""Words right before a place that make any verb a request to be taken there ("drive me to el6")."""

_STEMMER = snowballstemmer.stemmer("english")


def _stem(word: str) -> str:
    return str(_STEMMER.stemWord(word))


def _cue_shares() -> dict[str, dict[Intent, float]]:
    """Each content word of the trigger phrases (stemmed) and the share of its phrases per intent:
    "where" is all information, "get" mostly information, "take" half command, half feedback."""
    counts: dict[str, dict[Intent, int]] = {}
    for intent, phrases in TRIGGERS.items():
        for phrase in phrases:
            for word in set(phrase.split()) - CUE_STOP_WORDS:
                row = counts.setdefault(_stem(word), {})
                row[intent] = row.get(intent, 0) + 1
    return {
        stem: {intent: n / sum(row.values()) for intent, n in row.items()} for stem, row in counts.items()
    }


CUE_WORDS: dict[Intent, tuple[str, ...]] = _PHRASINGS.cue_words
"""Words (``phrasings.yaml``) that lean a sentence to an intent without being a trigger phrase's, wherever the place
stands ("is the canteen nearby", "are you fond of el6"): nearness and the way are questions of
where; liking is a question of opinion."""


def _with_cue_words(learnt: dict[str, dict[Intent, float]]) -> dict[str, dict[Intent, float]]:
    """:data:`CUE_WORDS` (stemmed, each all its intent's) over the cue words learnt from the triggers."""
    merged = dict(learnt)
    for intent, words in CUE_WORDS.items():
        for word in words:
            merged[_stem(word)] = {intent: 1.0}
    return merged


CUES: dict[str, dict[Intent, float]] = _with_cue_words(_cue_shares())
"""Cue words (stemmed) of the navigation intents, learnt from :data:`TRIGGERS`, and :data:`CUE_WORDS`."""


def classify_request(words: Sequence[str], place: LocationMatch) -> Intent | None:
    """The intent of a sentence that names ``place`` but holds no trigger phrase, from its other
    words (intent and slot).

    Each cue word (a content word of the trigger phrases, with any ending: "leading" for "lead",
    "directions" for "direction") adds its shares of the intents; words that send someone right
    before the place ("drive me to", "come with me to") make it a command, and so do words close
    to a trigger phrase there (a misheard "show me the wait on"). The leading intent needs
    :data:`CUE_SCORE` and a clear lead over the next; a negated command and a statement ("the
    lift is ...", "el6 is where i work") are none.
    """
    if not words or words[0] in STATEMENT_OPENERS or any(w in STATEMENT_WORDS for w in words):
        return None
    after = place.start + len(place.matched.split())
    said_of_place = place.start == 0 and words[after : after + 1] and words[after] in SUBJECT_VERBS
    if said_of_place and words[after + 1 : after + 2] not in (["it"], ["that"], ["this"], ["there"]):
        return None  # what the place is ("el6 is where i work"); "el5, is it near" asks
    span = range(place.start, place.start + len(place.matched.split()))
    lead = words[: place.start]
    if lead and lead[-1] == "the":
        lead = lead[:-1]
    before = " ".join(lead)
    scores: dict[Intent, float] = {}
    negated = any(w in NEGATIONS for w in lead)
    heard_as = max(  # the trigger phrase nearest to the words before the place; the longest on a tie
        (
            (fuzz.ratio(" ".join(lead[-len(p.split()) :]), p), len(p), intent)
            for intent, ps in TRIGGERS.items()
            for p in ps
        ),
        key=lambda t: t[:2],
    )
    if heard_as[0] >= FUZZY_TRIGGER_SCORE and heard_as[1] >= 10:
        scores[heard_as[2]] = 1.0
    name = normalise(place.location).split()
    for i, word in enumerate(words):  # a span heard roughly may hold a cue ("get the information desk")
        if i not in span or max(fuzz.ratio(word, n) for n in name) < DEFAULT_THRESHOLD:
            for intent, share in CUES.get(_stem(word), {}).items():
                scores[intent] = scores.get(intent, 0.0) + share
    if any(f" {before} ".endswith(f" {lead} ") for lead in ME_TO):
        scores[Intent.NAVIGATION_COMMAND] = scores.get(Intent.NAVIGATION_COMMAND, 0.0) + 1.0
    if not scores:
        return None
    ranked = sorted(scores.items(), key=lambda item: -item[1])
    intent, best = ranked[0]
    runner_up = ranked[1][1] if len(ranked) > 1 else 0.0
    if best < CUE_SCORE or best - runner_up < CUE_SCORE / 2:
        return None
    if intent is Intent.NAVIGATION_COMMAND and negated:
        return None
    return intent


def detect_navigation(text: str, matcher: LocationMatcher) -> Detection | None:
    """A navigation request in ``text``: a trigger phrase followed by a known place, or else the one
    known place of a sentence whose other words ask for it (:func:`classify_request`; such a
    request is not :attr:`~Detection.certain`: the robot asks before it acts).

    The earliest place wins; of the triggers before it, the one nearest to it, then the
    longest ("show me the way to" over "the way to"), unless a phrase that starts earlier runs
    into it ("how do you find" over "find the"); a negated command is none.
    """
    words = normalise(text).split()
    candidates: list[tuple[tuple[int, int, int], Intent, LocationMatch]] = []
    for intent, phrases in TRIGGERS.items():
        for phrase in phrases:
            after = _find_phrase(words, phrase)
            if after is None:
                continue
            size = len(phrase.split())
            if intent is Intent.NAVIGATION_COMMAND and _negated(words, after - size):
                continue
            match = matcher.find(" ".join(words[after:]))
            if match is not None:
                candidates.append(((after + match.start, -after, -size), intent, match))
    if not candidates:
        place = matcher.find(" ".join(words))
        if place is None:
            return None
        other = matcher.find(" ".join(words[place.start + len(place.matched.split()) :]))
        guessed = classify_request(words, place)
        if guessed is None or (other is not None and other.location != place.location):
            return None  # two places: which one is meant is a guess
        # Read from cue words rather than said in a known way: the place is asked about first.
        return Detection(guessed, place.location, place.matched, min(place.score, CERTAIN_SCORE - 1))
    (place_at, after, size), intent, match = min(candidates, key=lambda c: c[0])
    start = -after + size  # the keys hold -after and -size
    for (other_at, other_after, other_size), other_intent, other_match in candidates:
        # A longer phrase that runs into the nearest one is what was said: "how do you find the X"
        # is "how do you find", not "find the".
        other_start = -other_after + other_size
        if other_at == place_at and other_start < start < -other_after:
            start, intent, match = other_start, other_intent, other_match
    return Detection(intent, match.location, match.matched, match.score)


def detect_answer(text: str) -> Detection | None:
    """YES or NO if ``text`` holds yes-words or no-words but not both, and the answer comes first
    or the sentence is short ("okay then", "well, no"); None otherwise ("I said no to him yesterday")."""
    words = normalise(text).split()
    found: dict[Intent, tuple[int, str]] = {}
    taken: set[int] = set()
    phrases = [(p, Intent.YES) for p in YES_PHRASES] + [(p, Intent.NO) for p in NO_PHRASES]
    for phrase, intent in sorted(phrases, key=lambda p: -len(p[0].split())):
        target = phrase.split()
        for i in range(len(words) - len(target) + 1):
            span = set(range(i, i + len(target)))
            if words[i : i + len(target)] == target and not span & taken:
                taken |= span
                if intent is Intent.YES and i and words[i - 1] in NEGATIONS:
                    intent = Intent.NO  # "not right now", "not okay"
                found[intent] = min(found.get(intent, (i, phrase)), (i, phrase))
    if len(found) == 2 and words[0] in LEADING_NO:
        del found[Intent.YES]
    if len(found) != 1:
        return None
    [(intent, (first, phrase))] = found.items()
    if phrase in ENDING_ANSWERS and not set(words[first + len(phrase.split()) :]) <= ANSWER_COMPANIONS:
        return None
    if first > ANSWER_START and len(words) > SHORT_ANSWER:
        return None
    if intent is Intent.YES and phrase in WEAK_ANSWERS and not set(words) <= WEAK_ANSWERS | ANSWER_COMPANIONS:
        return None
    if intent is Intent.NO and phrase in WEAK_NO_ANSWERS and len(words) > WEAK_NO_WORDS:
        return None
    return Detection(intent, None, phrase, 100.0)


def detect(text: str, matcher: LocationMatcher) -> Detection | None:
    """The intent of one STT sentence: a navigation request first, else a yes/no answer, else None."""
    return detect_navigation(text, matcher) or detect_answer(text)
