"""What the robot would do with a sentence it heard (pure: no I/O).

The ears believe a transcript only when a module of the robot would act on it; this module
says which and how, with the modules' own detectors: a navigation request
(:func:`~cyborg.navigation.keywords.detect_navigation`, when the robot's modules listen for
its phrases), a greeting (:func:`~cyborg.modules.conversation.is_greeting`, when they listen
for greetings), a yes or no (:func:`~cyborg.navigation.keywords.detect_answer`), a place after
another module's phrase ("carry my bag to" the lift), or another module's phrase said on its
own (rapidfuzz, tolerant of small slips). Anything else is not understood and is rejected.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from rapidfuzz import fuzz

from cyborg.hearing.grammar import GREETING_FOLLOWERS, Grammar
from cyborg.modules.conversation import CONVERSATION_INTEREST, GREETING_PHRASES, GREETINGS, is_greeting
from cyborg.navigation.keywords import (
    TRIGGERS,
    Intent,
    LocationMatcher,
    detect_answer,
    detect_navigation,
    normalise,
)

__all__ = ["PHRASE_SCORE", "Understanding", "Understood"]

PHRASE_SCORE = 88.0
"""Lowest rapidfuzz ratio (0-100) at which a sentence counts as a module's phrase said on its own."""

_NAVIGATION_PHRASES = frozenset(p for phrases in TRIGGERS.values() for p in phrases)
_GREETINGS = frozenset(GREETINGS) | frozenset(GREETING_PHRASES)


@dataclass(frozen=True)
class Understood:
    """What the robot would do: the event a module raises (or the answer or phrase) and the place."""

    event: str
    """The controller's event ("navigation_information", "conversation_interest"), "yes" or "no"
    (an answer to a question the robot asked), or "phrase" (a module's own phrase)."""
    place: str | None = None
    phrase: str = ""
    """The words that made it understood."""
    certain: bool = True
    """False when the place was heard only roughly: the robot asks before it goes."""

    def describe(self) -> str:
        """One line for a person: ``navigation_information: cafeteria``, ``answer: yes``."""
        if self.event in ("yes", "no"):
            return f"answer: {self.event}"
        if self.event == "phrase":
            return f"phrase: {self.phrase}"
        place = f": {self.place}" if self.place else ""
        ask = " (asks first: did you mean it?)" if not self.certain else ""
        return f"{self.event}{place}{ask}"


class Understanding:
    """The detectors of the robot's modules over its places: ``of(text)`` says what it would do."""

    def __init__(
        self,
        places: Iterable[tuple[str, Iterable[str]]],
        phrases: Iterable[str],
        place_phrases: Iterable[str],
    ) -> None:
        """``places`` are (stored name, aliases); ``phrases`` and ``place_phrases`` what the modules
        listen for on their own and before a place (normalised words)."""
        self.matcher = LocationMatcher([(name, tuple(aliases)) for name, aliases in places])
        before_place = [normalise(p) for p in place_phrases]
        alone = [normalise(p) for p in phrases]
        self.navigation = any(p in _NAVIGATION_PHRASES for p in before_place)
        self.greetings = any(p in _GREETINGS for p in alone)
        self.answers = any(detect_answer(p) is not None for p in alone)
        self.other_place_phrases = tuple(p for p in before_place if p not in _NAVIGATION_PHRASES)
        self.other_phrases = tuple(
            p
            for p in alone
            if p
            and p not in _NAVIGATION_PHRASES
            and p not in _GREETINGS
            and p not in before_place
            and detect_answer(p) is None
        )

    @classmethod
    def of_grammar(cls, grammar: Grammar) -> Understanding:
        """The understanding of what ``grammar`` holds (its places' spoken forms and its phrases)."""
        names: dict[str, list[str]] = {}
        for form, name in grammar.place_forms.items():
            names.setdefault(name, [name]).append(form)
        return cls(names.items(), grammar.phrases, grammar.triggers)

    def of(self, text: str) -> Understood | None:
        """What the robot would do with ``text``, or None if no module acts on it."""
        words = normalise(text)
        if not words:
            return None
        if self.navigation:
            found = detect_navigation(words, self.matcher)
            if found is not None:
                return Understood(found.intent.value, found.location, found.matched, found.certain)
        for phrase in self.other_place_phrases:
            if f" {phrase} " in f" {words} ":
                place = self.matcher.find(words.split(f"{phrase} ", 1)[-1])
                if place is not None:
                    return Understood("phrase", place.location, phrase, place.certain)
        if self.greetings and is_greeting(words):
            return Understood(CONVERSATION_INTEREST, phrase=words)
        if self.answers:
            answer = detect_answer(words)
            if answer is not None:
                return Understood("yes" if answer.intent is Intent.YES else "no", phrase=answer.matched)
        for phrase in self.other_phrases:
            said = (phrase, *(f"{phrase} {f}" for f in GREETING_FOLLOWERS))
            if max(fuzz.ratio(words, s) for s in said) >= PHRASE_SCORE:
                return Understood("phrase", phrase=phrase)
        return None
