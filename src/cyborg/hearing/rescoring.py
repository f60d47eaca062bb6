"""Candidate transcripts for Whisper's second look at an utterance (pure: no I/O).

The beam search hears with the decoder primed by the robot's phrases; a second pass scores a few
candidate transcripts against the same encoder output, unprimed (:mod:`~cyborg.hearing.whisper`).
This module says which candidates, as Whisper would write them:

- for a request whose place was heard, the same words with each other place in the place's slot
  (:func:`place_variants`): when one of them is nearly as likely, the robot asks, never guesses;
- for a transcript nothing understands, the answers, greetings and phrases the robot understands that
  read most like it (:func:`repair_candidates`, from :func:`sentence_pool`), also spliced into the
  words heard around them.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence

from rapidfuzz import fuzz, process

from cyborg.navigation.keywords import NUMBER_WORDS

__all__ = [
    "REPAIR_RATIO",
    "place_variants",
    "repair_candidates",
    "sentence_pool",
    "written",
    "written_forms",
]

REPAIR_RATIO = 50.0
"""Lowest rapidfuzz ratio (0-100) between the transcript and a sentence the robot understands for
the sentence to be a candidate."""

PART_RATIO = 65.0
"""Lowest rapidfuzz partial ratio at which a sentence is spliced into the words around it."""
SPLICE_LOOK = 300
"""How many sentences that best match a part of the transcript are weighed for splicing (by how
much of them matched: a short one, "no", matches inside any "know")."""

_SPELLED = {
    "lets": "let's",
    "cant": "can't",
    "dont": "don't",
    "im": "I'm",
    "i": "I",
    "id": "I'd",
    "thats": "that's",
    "wheres": "where's",
    "whats": "what's",
    "youre": "you're",
}
"""The robot's words (no apostrophes) as Whisper writes them."""


def written(text: str, end: str = ".") -> str:
    """``text`` (the robot's lower-case words) as Whisper writes a transcript: ``"lets go to el6"`` ->
    ``" Let's go to el6."`` (a leading space, a capital, the end's punctuation)."""
    words = " ".join(_SPELLED.get(w, w) for w in text.split())
    return f" {words[:1].upper()}{words[1:]}{end}" if words else ""


def written_forms(place_forms: Mapping[str, str]) -> dict[str, list[str]]:
    """Each place's stored name and its one-word-per-sound aliases as Whisper writes them, from a
    grammar's spoken forms (``{"lift": "elevator", "el six": "el6"}`` -> ``{"elevator": ["elevator",
    "lift"], "el6": ["el6"]}``): a spoken form with a number word or a spelled letter is left out."""
    forms: dict[str, list[str]] = {}
    for form, name in place_forms.items():
        names = forms.setdefault(name, [name])
        words = form.split()
        if form not in names and not any(w in NUMBER_WORDS or len(w) == 1 for w in words):
            names.append(form)
    return forms


def _slot(form: str) -> list[str]:
    """How a place's form stands in a sentence: codes and numbered names bare (``el6``), others
    after ``the``."""
    return form.split() if re.search(r"\d", form) else ["the", *form.split()]


def place_variants(
    words: Sequence[str], start: int, stop: int, heard: str, forms: Mapping[str, Sequence[str]]
) -> list[tuple[str, str]]:
    """The sentence ``words`` with ``words[start:stop]`` (the place heard, ``heard``; a ``the`` before
    it goes with it) replaced by each other place's stored name: (place, words) pairs."""
    if start > 0 and words[start - 1] == "the":
        start -= 1
    return [
        (name, " ".join([*words[:start], *_slot(name), *words[stop:]])) for name in forms if name != heard
    ]


def sentence_pool(phrases: Iterable[str], greetings: Iterable[str], followers: Iterable[str]) -> list[str]:
    """The answers, greetings and phrases the robot understands on their own, in its words: each
    phrase, and each of the ``greetings`` also with each word that may follow it ("hello there")."""
    after, greeting = list(followers), set(greetings)
    return list(dict.fromkeys(s for p in phrases for s in (p, *(f"{p} {w}" for w in after if p in greeting))))


def repair_candidates(heard: str, pool: Sequence[str], limit: int) -> list[str]:
    """The ``limit`` sentences of ``pool`` that read most like ``heard`` (the robot's words), best first,
    each also spliced into the words heard around the part of ``heard`` it matches ("excuse me when is
    the lift" -> "excuse me where is the lift"); none below :data:`REPAIR_RATIO`."""
    if not heard:
        return []
    whole = [
        sentence
        for sentence, _, _ in process.extract(
            heard, pool, scorer=fuzz.ratio, limit=limit, score_cutoff=REPAIR_RATIO
        )
    ]
    parts = process.extract(
        heard, pool, scorer=fuzz.partial_ratio, limit=SPLICE_LOOK, score_cutoff=PART_RATIO
    )
    parts.sort(key=lambda found: -found[1] * len(found[0]))  # a long part matched, not a word
    spliced = [
        s for sentence, _, _ in parts if (s := _splice(heard, sentence)) is not None and s not in whole
    ]
    half = (limit + 1) // 2
    found = whole[:half] + spliced[: limit - half]
    found += [s for s in whole[half:] + spliced[limit - half :] if s not in found]
    return list(dict.fromkeys(found))[:limit]


def _splice(heard: str, sentence: str) -> str | None:
    """``sentence`` in place of the words of ``heard`` it lines up with, the rest of ``heard`` kept;
    None when it lines up with all of them, or when more words are kept than it puts back ("where is
    the wind" is no "where is the indeed")."""
    if len(sentence) >= len(heard):
        return None
    aligned = fuzz.partial_ratio_alignment(sentence, heard)
    if aligned is None:
        return None
    start = heard.rfind(" ", 0, aligned.dest_start + 1) + 1  # out to whole words
    stop = heard.find(" ", max(aligned.dest_end - 1, start))
    stop = len(heard) if stop < 0 else stop
    before, after = heard[:start].strip(), heard[stop:].strip()
    kept = len(before.split()) + len(after.split())
    if not kept or kept > len(sentence.split()):  # a repair puts back most of what was heard
        return None
    return " ".join(part for part in (before, sentence, after) if part)
