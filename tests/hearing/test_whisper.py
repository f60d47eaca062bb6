"""The default ears: Whisper tiny.en from the packaged model, primed with the robot's places, Silero VAD,
believing only what a module acts on; a missing or broken model names the fix and falls back to
pocketsphinx; nothing imports av (FFmpeg with GPL codecs) or downloads anything."""

from __future__ import annotations

import functools
import json
import logging
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cyborg.hearing import HearingError
from cyborg.hearing.grammar import PlaceWords
from cyborg.hearing.module import SpeechInput, SpeechInputSettings, grammar_of, recogniser_of
from cyborg.hearing.recogniser import Recogniser
from cyborg.hearing.synth import VOICES, synthesise
from cyborg.hearing.understanding import Understanding
from cyborg.hearing.vad import SileroUtterances
from cyborg.hearing.whisper import (
    ANSWER_MARGIN,
    DOUBT_MARGIN,
    PLACE_ODDS,
    REQUEST_MARGIN,
    WhisperRecogniser,
    collapse_repeats,
    prompt_of,
)
from cyborg.modules.kind import Listening
from cyborg.navigation.database import NavigationDatabase
from cyborg.transport import topics
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String


@pytest.fixture(scope="module")
def whisper(tmp_path_factory: pytest.TempPathFactory, listening: Listening) -> WhisperRecogniser:
    db = NavigationDatabase(tmp_path_factory.mktemp("nav") / "navigation.db")
    recogniser = WhisperRecogniser()
    places = [PlaceWords(p.name, p.aliases) for p in db.list_locations()]
    recogniser.use(grammar_of(places, recogniser, listening))
    db.close()
    return recogniser


def test_a_new_phrasing_is_heard_and_believed_and_out_of_scope_speech_is_not(
    whisper: WhisperRecogniser,
) -> None:
    heard = whisper.decode(synthesise("can you point me to the elevator", VOICES[3]))
    assert heard.accepted and heard.text == "can you point me to the elevator", heard
    assert 0.0 < heard.confidence <= 1.0
    understood = whisper.understanding.of(heard.text) if whisper.understanding else None
    assert understood is not None and (understood.event, understood.place) == (
        "navigation_information",
        "elevator",
    )
    other = whisper.decode(synthesise("how old are you", VOICES[3]))
    assert not other.accepted and other.reason == "not understood", other


def test_the_prompt_holds_every_place_and_follows_the_database(
    whisper: WhisperRecogniser, listening: Listening
) -> None:
    assert whisper.grammar is not None
    before = whisper._prompt
    grammar = grammar_of([PlaceWords("library", ("books",))], whisper, listening)
    whisper.use(grammar)
    try:
        text = whisper._tokenizer.decode(whisper._prompt[1:])
        assert "library" in text and "books" in text and "cafeteria" not in text
        assert len(whisper._prompt) <= 224
    finally:
        whisper._prompt = before


def test_understanding_accepts_the_ways_people_ask_and_rejects_the_rest(listening: Listening) -> None:
    understanding = Understanding(
        [("cafeteria", ["canteen"]), ("elevator", ["lift"])], listening.phrases, listening.place_phrases
    )
    said = {
        "I need to find the lift": "navigation_information: elevator",
        "take me to the canteen please": "navigation_command: cafeteria",
        "how do you feel about the cafeteria": "navigation_feedback: cafeteria",
        "hey there": "conversation_interest",
        "sure, go ahead": "answer: yes",
        "not right now": "answer: no",
    }
    for text, described in said.items():
        found = understanding.of(text)
        assert found is not None and found.describe() == described, text
    for text in ("how old are you", "the lift smells funny", "where is the library", "please be quiet"):
        assert understanding.of(text) is None, text


def test_silero_cuts_two_sentences_apart_and_ignores_noise() -> None:
    first, second = (synthesise(s, VOICES[0]) for s in ("where is the cafeteria", "yes"))
    pause = (np.random.default_rng(1).normal(0, 30, 16000).astype("<i2")).tobytes()
    cutter = SileroUtterances()
    found = [*cutter.feed(pause + first + pause + second + pause), *cutter.finish()]
    assert len(found) == 2
    assert 0.6 * len(first) < len(found[0]) < 1.3 * len(first)  # the speech, a little before and after
    assert [*cutter.feed(pause * 3), *cutter.finish()] == []


def test_silero_says_early_that_an_utterance_may_be_over_and_cuts_it_there() -> None:
    quiet = (np.random.default_rng(1).normal(0, 30, 16000).astype("<i2")).tobytes()
    audio = quiet + synthesise("where is the cafeteria", VOICES[0]) + quiet
    cutter = SileroUtterances(silence=0.3, early=0.1)
    tentative: list[bytes | None] = []
    found: list[bytes] = []
    for at in range(0, len(audio), 1024):  # 32 ms at a time
        found += cutter.feed(audio[at : at + 1024])
        if not found:
            tentative.append(cutter.tentative)
    assert tentative[0] is None and len(found) == 1
    assert tentative[-1] == found[0]  # said early, and cut where the tentative one was
    early = next(i for i, t in enumerate(tentative) if t == found[0])
    assert len(tentative) - early >= 5  # at least 0.16 s before the utterance was over
    assert cutter.tentative is None


def test_the_ears_decode_early_and_publish_the_same_text(
    whisper: WhisperRecogniser, listening: Listening, tmp_path: Path
) -> None:
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    published: list[str] = []
    transport.node("listener").subscribe(
        topics.TEXT_FROM_SPEECH, String, lambda m, i: published.append(m.data)
    )
    ears = SpeechInput(
        transport.node("ears"),
        NavigationDatabase(tmp_path / "navigation.db"),
        recogniser=whisper,
        listening=listening,
        utterances=SileroUtterances(),
    )
    quiet = bytes(2 * 16_000)

    async def main() -> None:
        await ears.listen_to(quiet + synthesise("where is the elevator", VOICES[3]) + quiet, live=True)
        await clock.sleep(0)

    try:
        clock.run(main())
    finally:
        ears.close()
        clock.close()
    assert published == ["where is the elevator"]
    assert (ears.early_decodes, ears.early_wasted) == (1, 0)


def test_a_place_is_believed_only_when_the_hypotheses_nearly_as_likely_name_it_too(
    whisper: WhisperRecogniser,
) -> None:
    assert whisper.understanding is not None
    heard = whisper.understanding.of("where is the entrance")
    assert heard is not None and heard.place == "entrance"
    near, far = -2.0 - DOUBT_MARGIN / 2, -2.0 - 2 * DOUBT_MARGIN
    assert whisper._rival(heard, -2.0, [("Where is the June?", 0.6, near)]) == "'where is the june'"
    assert whisper._rival(heard, -2.0, [("Where is the canteen?", 0.6, near)]) == "cafeteria"
    assert whisper._rival(heard, -2.0, [("Where is the June?", 0.6, far)]) is None  # far less likely
    assert whisper._rival(heard, -2.0, [("Where's the main entrance, then?", 0.6, near)]) is None


def test_a_misheard_answer_is_taken_from_a_hypothesis_nearly_as_likely_and_a_place_from_one_is_asked(
    whisper: WhisperRecogniser,
) -> None:
    rival = functools.partial(whisper._understood_rival, "short thing")
    near = -2.0 - ANSWER_MARGIN / 2
    assert rival(-2.0, [("Short thing.", 0.6, -2.1), ("Sure thing.", 0.6, near)]) == (
        "sure thing",
        whisper.understanding.of("sure thing") if whisper.understanding else None,
    )
    assert rival(-2.0, [("Sure thing.", 0.6, -2.0 - 2 * ANSWER_MARGIN)]) is None  # far less likely
    found = rival(-2.0, [("Hand it on the elevator.", 0.6, -2.1), ("Head to the elevator.", 0.6, -3.5)])
    assert found is not None and found[0] == "head to the elevator"
    assert (found[1].event, found[1].place) == ("navigation_command", "elevator")
    assert rival(-2.0, [("Head to the elevator.", 0.6, -2.0 - 2 * REQUEST_MARGIN)]) is None
    assert rival(-2.0, [("I like turtles.", 0.6, -2.1)]) is None  # nothing understood
    four = [("Where is the entrance or?", 0.6, -2.1)]  # entrance 4 is no place the robot knows
    assert whisper._understood_rival("where is the entrance 4", -2.0, four) is None


def test_another_place_scored_again_nearly_as_likely_is_asked_about_and_a_far_one_is_not(
    whisper: WhisperRecogniser,
) -> None:
    assert whisper.understanding is not None
    of = whisper.understanding.of
    _, cafeteria = whisper._search(synthesise("where is the cafeteria", VOICES[3]))
    waiting, said = of("where is the waiting area"), of("where is the cafeteria")
    assert waiting is not None and said is not None
    assert whisper._scored_rival(cafeteria, "where is the waiting area", waiting) == "cafeteria"
    assert whisper._scored_rival(cafeteria, "where is the cafeteria", said) is None
    _, el6 = whisper._search(synthesise("go to el6", VOICES[3]))
    elevator = of("go to the elevator")
    assert elevator is not None
    assert whisper._scored_rival(el6, "go to the elevator", elevator) == "el6"


def test_a_transcript_nothing_understands_is_repaired_when_a_sentence_understood_scores_as_well(
    whisper: WhisperRecogniser,
) -> None:
    _, sure = whisper._search(synthesise("sure thing", VOICES[3]))
    repaired = whisper._repaired(sure, " Short thing.", "short thing")
    assert repaired is not None and repaired[0] == "sure thing" and repaired[1].event == "yes"
    _, turtles = whisper._search(synthesise("i like turtles", VOICES[3]))
    assert whisper._repaired(turtles, " I like turtles.", "i like turtles") is None


def test_a_missing_model_names_the_fix_and_the_ears_fall_back_to_pocketsphinx(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with pytest.raises(HearingError, match=r"not installed.*fix: run scripts/setup"):
        WhisperRecogniser(model=tmp_path / "nowhere")
    with caplog.at_level(logging.WARNING):
        recogniser = recogniser_of(SpeechInputSettings(model=str(tmp_path / "nowhere")))
    assert isinstance(recogniser, Recogniser)
    assert "falls back to pocketsphinx" in caplog.text and "fix:" in caplog.text


def test_a_broken_model_names_the_fix(tmp_path: Path) -> None:
    (tmp_path / "model.bin").write_bytes(b"not a model")
    (tmp_path / "tokenizer.json").write_text("{}")
    with pytest.raises(HearingError, match=r"cannot be loaded.*fix: reinstall it"):
        WhisperRecogniser(model=tmp_path)


def test_hearing_imports_no_av_and_no_model_hub() -> None:
    script = (
        "import sys\n"
        "from cyborg.hearing.grammar import build_grammar\n"
        "from cyborg.hearing.synth import VOICES, synthesise\n"
        "from cyborg.hearing.vad import SileroUtterances\n"
        "from cyborg.hearing.whisper import WhisperRecogniser\n"
        "r = WhisperRecogniser(beam=1)\n"
        "r.use(build_grammar([], [], ['yes', 'no'], r.known_word))\n"
        "audio = synthesise('yes', VOICES[0])\n"
        "[utterance] = [*SileroUtterances().feed(audio + bytes(16000)), *SileroUtterances().finish()]\n"
        "print(r.decode(utterance).text)\n"
        "print(sorted(m for m in ('av', 'faster_whisper', 'huggingface_hub') if m in sys.modules))\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ["yes", "[]"]


def test_a_looping_decode_is_said_once() -> None:
    assert collapse_repeats("go to go to go to el6") == "go to el6"
    assert collapse_repeats("no no no no") == "no"
    assert collapse_repeats("where is the cafeteria") == "where is the cafeteria"


def test_the_prompt_can_also_hold_the_other_phrasings_within_whispers_budget(listening: Listening) -> None:
    grammar = grammar_of(
        [PlaceWords("cafeteria", ("canteen",)), PlaceWords("elevator")],
        WhisperRecogniser.__new__(WhisperRecogniser),
        listening,
    )
    plain = prompt_of(grammar)
    varied = prompt_of(grammar, phrasings=True)
    assert "Take me to the" not in plain and "Take me to the" in varied
    assert "Where do I find" not in varied  # one phrasing per set of cue words ("where can I find")
    places_last = "Where is the canteen? Go to the cafeteria. What do you think of the elevator?"
    assert plain.endswith(places_last) and varied.endswith(places_last)  # the places are kept
    assert round(1.4 * len(varied.split())) <= 223  # Whisper keeps no more of its prompt


def test_a_place_whisper_found_unlikely_is_in_doubt_whatever_the_words_around_it(
    listening: Listening,
) -> None:
    ears = WhisperRecogniser.__new__(WhisperRecogniser)
    ears.understanding = Understanding(
        [("entrance", []), ("entrance 2", []), ("el6", ["e16"])], listening.phrases, listening.place_phrases
    )
    sure = [(" Where", 0.9), (" is", 0.95), (" the", 0.2), (" entrance", 0.97), ("?", 0.1)]
    assert ears.place_odds(sure, "entrance") == 0.97  # "the" and "?" are no place
    gym = [(" Where", 0.9), (" is", 0.95), (" the", 0.9), (" entrance", 0.31), ("?", 0.9)]
    assert ears.place_odds(gym, "entrance") == 0.31
    six = [(" Where", 0.9), (" is", 0.9), (" el", 0.95), ("6", 0.4), (".", 0.9)]
    assert ears.place_odds(six, "el6") == 0.4  # el5 or el6: the digit decides
    looped = [*sure[:4], ("?", 0.9), (" Where", 0.9), (" is", 0.9), (" the", 0.9), (" entrance", 0.01)]
    assert ears.place_odds(looped, "entrance") == 0.97  # the first time it is said
    two = [(" Go", 0.9), (" to", 0.9), (" entrance", 0.9), (" number", 0.3), (" two", 0.6), (".", 0.9)]
    assert ears.place_odds(two, "entrance 2") == 0.3  # entrance 2, said "entrance number two"
    assert ears.place_odds([(" Hello", 0.2), (" there", 0.1)], "el6") == 1.0  # no place


def test_a_doubted_place_goes_to_the_unsure_topic_and_never_to_the_text(
    whisper: WhisperRecogniser, listening: Listening, tmp_path: Path
) -> None:
    whisper.place_doubt = 1.01  # every place in doubt
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    text: list[str] = []
    unsure: list[dict[str, object]] = []
    listener = transport.node("listener")
    listener.subscribe(topics.TEXT_FROM_SPEECH, String, lambda m, i: text.append(m.data))
    listener.subscribe(topics.SPEECH_UNSURE, String, lambda m, i: unsure.append(json.loads(m.data)))
    ears = SpeechInput(
        transport.node("ears"),
        NavigationDatabase(tmp_path / "navigation.db"),
        recogniser=whisper,
        listening=listening,
        utterances=SileroUtterances(),
    )
    quiet = bytes(2 * 16_000)

    async def main() -> None:
        for said in ("where is the elevator", "yes"):
            await ears.listen_to(quiet + synthesise(said, VOICES[3]) + quiet)
        await clock.sleep(0)

    try:
        clock.run(main())
    finally:
        whisper.place_doubt = PLACE_ODDS
        ears.close()
        clock.close()
    assert text == ["yes"]  # an answer names no place: believed
    [doubt] = unsure
    assert doubt["text"] == "where is the elevator" and doubt["place"] == "elevator"
    assert str(doubt["reason"]).startswith("unsure of the place: elevator")
