"""What users say in the thesis's chapter 10 scenarios, synthesised by espeak-ng and flite, is heard as
text that gives the same event (a place asked about first: pocketsphinx's posteriors cannot tell a
misheard place); speech outside the grammar is rejected; a missing microphone is a clear error."""

from __future__ import annotations

from pathlib import Path

import pytest

from cyborg.hearing import HearingError
from cyborg.hearing.audio import Microphone, read_wav
from cyborg.hearing.grammar import PlaceWords
from cyborg.hearing.module import grammar_of
from cyborg.hearing.recogniser import Recogniser
from cyborg.hearing.synth import VOICES, synthesise
from cyborg.modules.conversation import is_greeting
from cyborg.modules.kind import Listening
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.keywords import detect_answer, detect_navigation
from tests.support.paths import SCENARIOS

SCENARIO_LINES = [  # every line a user says in tests/scenarios/scenario_*.yaml
    "hello",
    "What do you think of el6?",
    "Where is el6 ?",
    "Where is the cafeteria ?",
    "go to entrance 2",
    "where is the e16",
    "yes",
]
TEST_VOICES = [VOICES[0], VOICES[1], VOICES[3], VOICES[6]]  # espeak-ng en, en-us; flite slt, rms


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> NavigationDatabase:
    return NavigationDatabase(tmp_path_factory.mktemp("nav") / "navigation.db")


@pytest.fixture(scope="module")
def recogniser(db: NavigationDatabase, listening: Listening) -> Recogniser:
    recogniser = Recogniser()
    places = [PlaceWords(p.name, p.aliases) for p in db.list_locations()]
    recogniser.use(grammar_of(places, recogniser, listening))
    return recogniser


def event_of(text: str, db: NavigationDatabase) -> str | None:
    """The event a module raises for ``text`` (navigation's intent and place, or a greeting)."""
    if is_greeting(text):
        return "conversation_interest"
    found = detect_navigation(text, db.matcher()) or detect_answer(text)
    return f"{found.intent.value}:{found.location}" if found else None


def test_the_scenario_lines_in_the_tests_are_those_of_the_scenarios() -> None:
    said = set()
    for path in SCENARIOS.glob("scenario_*.yaml"):
        said |= {
            line.split("say:", 1)[1].strip().strip('"')
            for line in path.read_text().splitlines()
            if "say:" in line
        }
    assert {s.lower() for s in said} - {s.lower() for s in SCENARIO_LINES} == set()


@pytest.mark.parametrize("voice", TEST_VOICES, ids=str)
def test_every_scenario_line_gives_the_same_event_as_typed(
    voice: object, recogniser: Recogniser, db: NavigationDatabase
) -> None:
    for line in SCENARIO_LINES:
        heard = recogniser.decode(synthesise(line, voice))  # type: ignore[arg-type]
        expected = event_of(line, db)
        request = detect_navigation(line, db.matcher())
        place = request.location if request is not None else None
        # A place pocketsphinx hears is always asked about ("Did you mean the el6?"): never believed.
        assert heard.accepted == (place is None), f"{line!r}: heard {heard.raw!r} ({heard.reason})"
        assert heard.ask == place, f"{line!r} heard as {heard.text!r}, asks about {heard.ask}"
        assert event_of(heard.text, db) == expected, f"{line!r} heard as {heard.text!r}"


def test_speech_outside_the_grammar_is_rejected(recogniser: Recogniser) -> None:
    for sentence in ("what is the weather like today", "thank you very much", "where is the library"):
        heard = recogniser.decode(synthesise(sentence, VOICES[0]))
        assert not heard.accepted, f"{sentence!r} taken as {heard.text!r} ({heard.confidence:.2f})"


def test_a_missing_microphone_names_the_fix() -> None:
    with pytest.raises(HearingError, match=r"fix: .*--wav FILE"):
        Microphone(lambda chunk: None, device="no such microphone")


def test_a_file_that_is_not_a_wav_names_the_fix(tmp_path: Path) -> None:
    bad = tmp_path / "notes.wav"
    bad.write_text("hello")
    with pytest.raises(HearingError, match=r"not a WAV file.*fix"):
        read_wav(bad)
