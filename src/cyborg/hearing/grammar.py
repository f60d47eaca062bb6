"""What the robot can hear, built from what it understands (pure: no I/O).

The grammar is a JSGF text for pocketsphinx: requests for a place (a phrase that takes a
place, like "where is", then one of the places or their aliases), and phrases on their own
(greetings, yes and no answers, and whatever else modules declare they listen for). Place
names are turned into words the pronouncing dictionary knows: digits become number words
("entrance 2" -> "entrance two") and unknown letter groups are spelled ("e16" -> "e sixteen").
:meth:`Grammar.canonical` maps what was heard back to the place's stored name.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import cached_property

from cyborg.navigation.keywords import NUMBER_WORDS

__all__ = [
    "ALWAYS_HEARD",
    "LEAD_INS",
    "PLACE_SUFFIXES",
    "Grammar",
    "PlaceWords",
    "build_grammar",
    "spoken_forms",
]

ALWAYS_HEARD = ("hello", "hi", "good morning", "good afternoon", "good evening", "yes", "no")
"""Greetings and answers the robot hears even when no configured module declares them (a question
module takes any answer; the dashboard shows what was said)."""

LEAD_INS = ("what do you", "how do you", "can you", "could you", "please", "do you know")
"""Words people put before a phrase that takes a place ("what do you think of", "can you go to")."""

PLACE_SUFFIXES = ("please",)
"""Words people put after a place ("go to the cafeteria please")."""

GREETING_FOLLOWERS = ("there", "cyborg", "robot")
"""Words that may follow a greeting ("hello there")."""

_ONES = sorted((w for w, n in NUMBER_WORDS.items() if int(n) < 20), key=lambda w: int(NUMBER_WORDS[w]))
"""zero ... nineteen: the navigation module's own number words (keywords.NUMBER_WORDS)."""
_TENS = ["_", "_", "twenty", "thirty", "forty", "fifty", "sixty", "seventy", "eighty", "ninety"]


@dataclass(frozen=True)
class PlaceWords:
    """A place as the navigation database stores it: its name and aliases."""

    name: str
    aliases: tuple[str, ...] = ()


def number_words(digits: str) -> list[str]:
    """``"16"`` -> ``["sixteen"]``; ``"42"`` -> ``["forty", "two"]``; longer numbers digit by digit."""
    n = int(digits)
    if len(digits) <= 2 and not (len(digits) == 2 and digits[0] == "0"):
        if n < 20:
            return [_ONES[n]]
        return [_TENS[n // 10]] + ([_ONES[n % 10]] if n % 10 else [])
    return [_ONES[int(d)] for d in digits]


def normalise(text: str) -> str:
    """Lower case, words only: ``"Where is the Cafeteria ?"`` -> ``"where is the cafeteria"``."""
    return " ".join(re.findall(r"[a-z0-9æøå']+", text.lower())).replace("'", "")


def spoken_forms(name: str, known_word: Callable[[str], bool]) -> list[str]:
    """The ways ``name`` is said, in words ``known_word`` accepts (none if it cannot be said).

    ``"el6"`` -> ``["el six", "e l six"]``; ``"entrance 2"`` -> ``["entrance two"]``.
    """
    variants: list[list[str]] = [[]]
    for token in re.findall(r"[a-z]+|[0-9]+", name.lower()):
        if token.isdigit():
            options = [number_words(token)]
        else:
            options = []
            if known_word(token):
                options.append([token])
            if len(token) <= 3 and all(known_word(letter) for letter in token):
                spelled = list(token)
                if spelled not in options:
                    options.append(spelled)
            if not options:
                return []
        variants = [v + o for v in variants for o in options]
    forms = [" ".join(v) for v in variants if v]
    return [f for i, f in enumerate(forms) if f not in forms[:i]]


@dataclass(frozen=True)
class Grammar:
    """A JSGF grammar and the map from each spoken place form back to the place's name."""

    jsgf: str
    place_forms: dict[str, str] = field(default_factory=dict)
    phrases: tuple[str, ...] = ()
    """Phrases said on their own, in the order they were declared."""
    unsayable: tuple[str, ...] = ()
    """Places and phrases left out: a word the dictionary does not know."""
    triggers: tuple[str, ...] = ()
    """Phrases that take a place ("where is"), as said."""

    @property
    def request_parts(self) -> list[tuple[str, ...]]:
        """The slots of a request, in order; ``""`` in a slot means it may be left out."""
        if not (self.triggers and self.place_forms):
            return []
        return [
            ("", *LEAD_INS),
            self.triggers,
            ("", "the"),
            tuple(sorted(self.place_forms)),
            ("", *PLACE_SUFFIXES),
        ]

    def sentences(self) -> list[str]:
        """Every sentence of the grammar (requests for every place in every form, and the phrases)."""
        found = [
            " ".join(word for word in choice if word) for choice in itertools.product(*self.request_parts)
        ]
        found += [f"{p} {f}".strip() for p in self.phrases for f in ("", *GREETING_FOLLOWERS)]
        return found

    @cached_property
    def _pattern(self) -> re.Pattern[str]:
        def slot(options: tuple[str, ...]) -> str:
            words = "|".join(re.escape(o) for o in options if o)
            return f"(?:(?:{words}) )?" if "" in options else f"(?:{words}) "

        alternatives = []
        if self.request_parts:
            alternatives.append("".join(slot(part) for part in self.request_parts))
        if self.phrases:
            alternatives.append(slot(self.phrases) + slot(("", *GREETING_FOLLOWERS)))
        return re.compile("|".join(alternatives) or "(?!)")

    def holds(self, sentence: str) -> bool:
        """Whether ``sentence`` (the dictionary's words) is a whole sentence of the grammar."""
        return bool(sentence) and self._pattern.fullmatch(f"{sentence} ") is not None

    def canonical(self, heard: str) -> str:
        """``heard`` with a spoken place form replaced by the stored name (the longest form first)."""
        text = f" {heard} "
        for form in sorted(self.place_forms, key=len, reverse=True):
            if f" {form} " in text:
                return text.replace(f" {form} ", f" {self.place_forms[form]} ", 1).strip()
        return heard


def _alternatives(items: Iterable[str]) -> str:
    return " | ".join(sorted(set(items)))


def build_grammar(
    places: Iterable[PlaceWords],
    place_phrases: Iterable[str],
    phrases: Iterable[str],
    known_word: Callable[[str], bool],
) -> Grammar:
    """The grammar of requests for ``places`` (after one of ``place_phrases``) and of ``phrases``.

    ``known_word`` says whether the pronouncing dictionary has a word; phrases with other words
    are left out (listed in :attr:`Grammar.unsayable`).
    """
    unsayable: list[str] = []

    def sayable(text: str) -> bool:
        ok = bool(text) and all(known_word(w) for w in text.split())
        if text and not ok:
            unsayable.append(text)
        return ok

    forms: dict[str, str] = {}
    for place in places:
        for said in (place.name, *place.aliases):
            found = spoken_forms(said, known_word)
            if not found:
                unsayable.append(said)
            for form in found:
                forms.setdefault(form, place.name)
    triggers = [p for p in (normalise(p) for p in place_phrases) if sayable(p)]
    alone = [p for p in (normalise(p) for p in phrases) if sayable(p)]
    if not alone and not (triggers and forms):
        alone = ["hello"]
    rules = ["#JSGF V1.0;", "grammar robot;"]
    public = []
    if triggers and forms:
        public.append("<request>")
        rules += [
            f"<lead> = {_alternatives(LEAD_INS)};",
            f"<trigger> = {_alternatives(triggers)};",
            f"<place> = {_alternatives(forms)};",
            f"<request> = [<lead>] <trigger> [the] <place> [{_alternatives(PLACE_SUFFIXES)}];",
        ]
    if alone:
        public.append("<phrase>")
        rules.append(f"<phrase> = ({_alternatives(alone)}) [{_alternatives(GREETING_FOLLOWERS)}];")
    rules.insert(2, f"public <heard> = {' | '.join(public)};")
    return Grammar(
        "\n".join(rules) + "\n",
        forms,
        tuple(dict.fromkeys(alone)),
        tuple(unsayable),
        tuple(dict.fromkeys(triggers)) if forms else (),
    )
