"""Keyword detection in STT text: intents, tolerant place names, yes/no answers."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cyborg.errors import ConfigError
from cyborg.navigation.keywords import (
    PHRASINGS_FILE,
    Intent,
    LocationMatcher,
    detect,
    detect_answer,
    detect_navigation,
    load_phrasings,
    normalise,
)

PLACES = [
    ("information desk", ["info"]),
    ("cafeteria", []),
    ("entrance", []),
    ("entrance 2", ["entrance2"]),
    ("el5", []),
    ("el6", ["e16"]),
    ("waiting area", []),
    ("elevator", []),
]
MATCHER = LocationMatcher(PLACES)
CMD, INFO, FEEDBACK = Intent.NAVIGATION_COMMAND, Intent.NAVIGATION_INFORMATION, Intent.NAVIGATION_FEEDBACK


@pytest.mark.parametrize(
    ("text", "intent", "location"),
    [
        # the spec's scenarios
        ("What do you think of el6?", FEEDBACK, "el6"),
        ("Where is the cafeteria ?", INFO, "cafeteria"),
        ("go to entrance 2", CMD, "entrance 2"),
        ("Where is el6 ?", INFO, "el6"),
        ("where is the e16", INFO, "el6"),
        ("where is entrance number 2", INFO, "entrance 2"),  # not the entrance
        ("travel to entrance 2", CMD, "entrance 2"),
        # case, punctuation, filler words
        ("GO TO THE CAFETERIA!!!", CMD, "cafeteria"),
        ("Could you please move to the waiting area, robot?", CMD, "waiting area"),
        ("where's the elevator", INFO, "elevator"),
        ("Where is the information desk?", INFO, "information desk"),
        ("where is info", INFO, "information desk"),
        # speech-to-text errors
        ("go to the cafeteriaa", CMD, "cafeteria"),
        ("where is the cafetria", INFO, "cafeteria"),
        ("go to the entrence", CMD, "entrance"),
        ("move to the waiting aria", CMD, "waiting area"),
        ("go to el 6", CMD, "el6"),
        ("go to el six", CMD, "el6"),
        ("where is e sixteen", INFO, "el6"),
        ("go to el five", CMD, "el5"),
        ("go to entrance two", CMD, "entrance 2"),
        ("go to entrance-2", CMD, "entrance 2"),
        ("go to entrance2", CMD, "entrance 2"),
        ("go to the entrance", CMD, "entrance"),
        ("what do you think about the elevater", FEEDBACK, "elevator"),
    ],
)
def test_navigation_requests_are_detected(text: str, intent: Intent, location: str) -> None:
    found = detect(text, MATCHER)
    assert found is not None, text
    assert (found.intent, found.location) == (intent, location)
    assert MATCHER.threshold <= found.score <= 100


@pytest.mark.parametrize(
    "text",
    [
        "go to bed",
        "go to hell",
        "go to el",
        "go to el7",
        "go to entrance 3",
        "where is the toilet",
        "where is my dog",
        "I think of nothing",
        "cafeteria",  # a place but no request
        "i saw you near the cafeteria",  # a statement about the past
        "where is entrance number 3",
        "go to the",
        "",
        "?!.",
    ],
)
def test_unrelated_text_is_not_a_navigation_request(text: str) -> None:
    assert detect_navigation(text, MATCHER) is None


def test_the_place_must_come_after_the_trigger() -> None:
    assert detect_navigation("cafeteria, go to", MATCHER) is None


def test_earliest_trigger_and_earliest_place_win() -> None:
    found = detect("where is the cafeteria, or go to the elevator", MATCHER)
    assert found is not None
    assert (found.intent, found.location) == (INFO, "cafeteria")
    found = detect("go to the cafeteria near the entrance", MATCHER)
    assert found is not None and found.location == "cafeteria"


def test_longer_name_wins_over_its_prefix() -> None:
    for text, expected in [("go to entrance 2 now", "entrance 2"), ("go to entrance now", "entrance")]:
        found = detect(text, MATCHER)
        assert found is not None and found.location == expected, text


def test_matched_text_is_the_words_heard() -> None:
    found = detect("Go to the Cafetria, please", MATCHER)
    assert found is not None
    assert found.matched == "cafetria"
    assert found.score < 100


@pytest.mark.parametrize(
    ("text", "intent"),
    [
        ("yes", Intent.YES),
        ("Yes!", Intent.YES),
        ("yeah", Intent.YES),
        ("Sure.", Intent.YES),
        ("ok", Intent.YES),
        ("okay then", Intent.YES),
        ("yes please", Intent.YES),
        ("why not", Intent.YES),
        ("of course", Intent.YES),
        ("no", Intent.NO),
        ("No.", Intent.NO),
        ("nope", Intent.NO),
        ("no thanks", Intent.NO),
        ("not really", Intent.NO),
        ("I don't", Intent.NO),
    ],
)
def test_yes_and_no(text: str, intent: Intent) -> None:
    found = detect(text, MATCHER)
    assert found is not None and found.intent is intent, text
    assert found.location is None


@pytest.mark.parametrize("text", ["yes no", "ok, no", "hello", "cafeteria", "knowledge", "yesterday", ""])
def test_ambiguous_or_missing_answers_are_none(text: str) -> None:
    assert detect_answer(text) is None


def test_navigation_takes_precedence_over_yes() -> None:
    found = detect("yes, go to the cafeteria", MATCHER)
    assert found is not None and found.intent is CMD


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("Where's  Entrance-Two?", "wheres entrance 2"),
        ("EL 6!", "el 6"),
        ("e sixteen", "e 16"),
        ("go to the ... cafeteria", "go to the cafeteria"),
        ("Glassgården", "glassgården"),
        ("entrance number two", "entrance 2"),
        ("my number is 5", "my number is 5"),
    ],
)
def test_normalise(text: str, expected: str) -> None:
    assert normalise(text) == expected


@given(st.text())
def test_normalise_is_idempotent(text: str) -> None:
    once = normalise(text)
    assert normalise(once) == once


@given(st.sampled_from([name for name, _ in PLACES]), st.sampled_from(["go to", "move to"]))
def test_every_place_is_found_by_its_own_name(name: str, trigger: str) -> None:
    found = detect(f"{trigger} the {name}", MATCHER)
    assert found is not None and found.location == name


@given(st.sampled_from(["cafeteria", "elevator", "entrance", "waiting area"]), st.data())
def test_one_dropped_letter_in_a_long_name_still_matches(name: str, data: st.DataObject) -> None:
    letters = [i for i, c in enumerate(name) if c != " "]
    i = data.draw(st.sampled_from(letters))
    heard = name[:i] + name[i + 1 :]
    found = detect(f"where is the {heard}", MATCHER)
    assert found is not None and found.location == name, heard


def test_threshold_controls_tolerance() -> None:
    strict = LocationMatcher(PLACES, threshold=100)
    assert detect("go to the cafetria", strict) is None
    assert detect("go to the cafeteria", strict) is not None
    with pytest.raises(ValueError, match="threshold"):
        LocationMatcher(PLACES, threshold=0)


def test_matcher_lists_names_once() -> None:
    assert MATCHER.names == [name for name, _ in PLACES]


@pytest.mark.parametrize(
    ("text", "intent", "location"),
    [  # how people ask, beyond the thesis's three phrasings
        ("can you point me to the cafeteria", INFO, "cafeteria"),
        ("I need to find the elevator", INFO, "elevator"),
        ("how can I reach entrance 2", INFO, "entrance 2"),
        ("where exactly is the information desk", INFO, "information desk"),
        ("how do I go to the cafeteria", INFO, "cafeteria"),
        ("take me to the waiting area", CMD, "waiting area"),
        ("show me the way to el5", CMD, "el5"),
        ("drive over to the elevator", CMD, "elevator"),
        ("what's your opinion of the cafeteria", FEEDBACK, "cafeteria"),
        ("do you like the elevator", FEEDBACK, "elevator"),
    ],
)
def test_many_phrasings_of_a_request_are_understood(text: str, intent: Intent, location: str) -> None:
    found = detect(text, MATCHER)
    assert found is not None and (found.intent, found.location) == (intent, location), text


def test_a_negated_command_is_none() -> None:
    assert detect_navigation("don't go to the cafeteria", MATCHER) is None
    assert detect_navigation("please do not drive to the elevator", MATCHER) is None
    assert detect_navigation("I don't want to go to the cafeteria", MATCHER) is None
    assert detect_navigation("please don't ride with me to el6", MATCHER) is None


@pytest.mark.parametrize(
    ("text", "intent", "location"),
    [  # no trigger phrase in these: the place and the other words say what is asked
        ("could you escort us over to the cafeteria", CMD, "cafeteria"),
        ("ride with me to the elevator", CMD, "elevator"),
        ("guiding me towards the waiting area, please", CMD, "waiting area"),
        ("el5, where is that", INFO, "el5"),
        ("directions for the information desk please", INFO, "information desk"),
        ("locating entrance 2 is hard", INFO, "entrance 2"),
        ("your opinion, the waiting area?", FEEDBACK, "waiting area"),
        ("show me the wait on the information desk", CMD, "information desk"),  # a misheard "way to"
        ("is the cafeteria close to here", INFO, "cafeteria"),  # nearness asks the way
        ("el5, is it near", INFO, "el5"),
        ("would you say the cafeteria is pleasant", FEEDBACK, "cafeteria"),  # liking asks an opinion
        ("are you fond of el6", FEEDBACK, "el6"),
        ("how do you find the waiting area", FEEDBACK, "waiting area"),  # not "find the"
    ],
)
def test_a_request_without_a_trigger_phrase_is_read_from_its_cue_words(
    text: str, intent: Intent, location: str
) -> None:
    found = detect_navigation(text, MATCHER)
    assert found is not None and (found.intent, found.location) == (intent, location), text


@pytest.mark.parametrize(
    "text",
    [
        "my friend is looking at the elevator",  # a statement, not a request
        "the cafeteria is where we met",
        "I had lunch in the cafeteria",  # no cue word
        "el6 and el5",
        "show me the cafeteria and go",  # cue words of two intents, neither leading clearly
    ],
)
def test_a_place_without_a_request_is_none(text: str) -> None:
    assert detect_navigation(text, MATCHER) is None, text


@pytest.mark.parametrize(
    ("text", "intent"),
    [
        ("not right now", Intent.NO),
        ("please", Intent.YES),
        ("that would be great", Intent.YES),
        ("maybe another time", Intent.NO),
        ("turn around please", None),
        ("I said no to him yesterday at the bus stop", None),
        ("never", Intent.NO),
        ("I do not like him at home", None),  # "do not" and "never" answer only in a short sentence
        ("it never rains here in the summer", None),
        ("no, that's okay", Intent.NO),  # a leading no wins over the yes-words after it
        ("nope, sure", Intent.NO),
        ("I'd rather not", Intent.NO),
        ("yeah, let's go", Intent.YES),
        ("let's go dancing", None),  # "let's go" answers only at the end
    ],
)
def test_answers_said_many_ways_and_not_hidden_in_other_sentences(text: str, intent: Intent | None) -> None:
    found = detect_answer(text)
    assert (found.intent if found else None) is intent, text


def test_a_place_heard_roughly_is_found_but_not_certain() -> None:
    rough = detect("where is the a16", MATCHER)
    assert rough is not None and rough.location == "el6" and not rough.certain
    clear = detect("where is the e16", MATCHER)
    assert clear is not None and clear.certain
    assert detect("where is the a17", MATCHER) is None  # other digits: never that place


def test_a_phrase_heard_with_another_determiner_is_still_the_phrase() -> None:
    for text in ("show me that way to the cafeteria", "show me my way to the cafeteria please"):
        found = detect_navigation(text, MATCHER)
        assert found is not None and (found.intent, found.location) == (CMD, "cafeteria"), text


def test_a_question_of_the_floor_is_asked_about_and_a_statement_about_a_place_is_none() -> None:
    found = detect_navigation("is el6 upstairs", MATCHER)
    assert found is not None and (found.intent, found.location, found.certain) == (INFO, "el6", False)
    assert detect_navigation("el6 is where i work", MATCHER) is None


def test_a_place_followed_by_a_letter_or_numeral_is_asked_about_not_taken() -> None:
    for text in ("where is the entrance i", "where is the entrance b please", "go to the cafeteria iv"):
        found = detect_navigation(text, MATCHER)  # another place's name misheard ("entrance 5")?
        assert found is not None and not found.certain, text
    assert detect_navigation("where is the entrance 5", MATCHER) is None  # a number: not the entrance
    said = detect_navigation("where is the entrance i need to go", MATCHER)
    assert said is not None and said.location == "entrance" and said.certain  # a pronoun, not a suffix


def test_a_place_followed_by_a_word_not_of_its_name_is_asked_about_unless_it_ends_the_request() -> None:
    found = detect_navigation("where is the cafeteria shop", MATCHER)  # "the gift shop", misheard?
    assert found is not None and found.location == "cafeteria" and not found.certain
    for text in ("where is the cafeteria located", "take me to the cafeteria again please"):
        found = detect_navigation(text, MATCHER)
        assert found is not None and found.location == "cafeteria" and found.certain, text


def test_a_number_heard_as_a_word_is_not_certain_even_before_polite_words() -> None:
    for text in (
        "where is the entrance to",
        "go to the entrance to please",
        "get me over to entrance to, thanks",
    ):
        found = detect_navigation(text, MATCHER)
        assert found is not None and found.location == "entrance 2" and not found.certain, text
    plain = detect_navigation("go to the entrance please", MATCHER)
    assert plain is not None and plain.location == "entrance" and plain.certain


def test_the_phrasings_are_content_and_a_broken_file_names_the_entry_and_the_fix(tmp_path: Path) -> None:
    shipped = PHRASINGS_FILE.read_text(encoding="utf-8")
    added = tmp_path / "phrasings.yaml"
    added.write_text(
        shipped.replace("    - go to\n", "    - go to\n    - zoom over to\n", 1), encoding="utf-8"
    )
    assert "zoom over to" in load_phrasings(added).requests[CMD]
    broken = tmp_path / "broken.yaml"
    broken.write_text(
        shipped.replace("    - go to\n", "    - Go to!\n", 1).replace(
            "requests:\n", "requests:\n  navigation_dance: [x]\n", 1
        ),
        encoding="utf-8",
    )
    with pytest.raises(ConfigError) as raised:
        load_phrasings(broken)
    message = str(raised.value)
    assert "requests.navigation_dance: no such request; fix: use one of navigation_command" in message
    assert "'Go to!' is not as the robot reads speech; fix: write 'go to'" in message
    assert "plain: 'go to' is no request or answer of the file" in message  # it was renamed above
