"""Candidates for Whisper's second look: the words heard with another place in the place's slot, and
the sentences the robot understands that read most like a transcript nothing understood."""

from __future__ import annotations

from cyborg.hearing.rescoring import (
    place_variants,
    repair_candidates,
    sentence_pool,
    written,
    written_forms,
)

FORMS = {"elevator": ["elevator", "lift"], "el6": ["el6"], "waiting area": ["waiting area"]}


def test_a_transcript_is_written_as_whisper_writes_it() -> None:
    assert written("lets go to el6") == " Let's go to el6."
    assert written("where is the lift", "?") == " Where is the lift?"
    assert written("im fine") == " I'm fine."
    assert written("") == ""


def test_the_written_forms_are_names_and_word_aliases_not_spelled_or_number_words() -> None:
    spoken = {
        "lift": "elevator",
        "elevator": "elevator",
        "el six": "el6",
        "e l six": "el6",
        "entrance two": "entrance 2",
        "main entrance": "entrance",
    }
    assert written_forms(spoken) == {
        "elevator": ["elevator", "lift"],
        "el6": ["el6"],
        "entrance 2": ["entrance 2"],
        "entrance": ["entrance", "main entrance"],
    }


def test_each_other_place_takes_the_slot_of_the_place_heard_with_its_the() -> None:
    words = ["go", "to", "the", "elevator", "now"]
    assert place_variants(words, 3, 4, "elevator", FORMS) == [
        ("el6", "go to el6 now"),
        ("waiting area", "go to the waiting area now"),
    ]
    assert place_variants(["where", "is", "el6"], 2, 3, "el6", FORMS) == [
        ("elevator", "where is the elevator"),
        ("waiting area", "where is the waiting area"),
    ]


def test_the_pool_holds_each_phrase_and_each_greeting_with_each_follower() -> None:
    assert sentence_pool(["hello", "never"], ["hello"], ["there"]) == ["hello", "hello there", "never"]


def test_the_repair_candidates_read_like_the_transcript_and_keep_the_words_around_them() -> None:
    pool = sentence_pool(["sure thing", "no", "sounds good", "indeed", "hello"], ["hello"], ["there"])
    assert repair_candidates("short thing", pool, 4)[0] == "sure thing"
    assert "sounds good to me" in repair_candidates("sound is good to me", pool, 8)
    assert "where is the indeed" not in repair_candidates("where is the wind", pool, 8)
    assert repair_candidates("hello there", pool, 1) == ["hello there"]  # at most the limit
    assert repair_candidates("", pool, 4) == []
    assert repair_candidates("zzz qqq", pool, 4) == []  # nothing reads like it
