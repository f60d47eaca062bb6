"""A full voice loop: the robot hears a synthesised "where is the cafeteria" (with the default
engine, Whisper tiny.en from the packaged model, and Silero VAD), offers to show the way (its
text-to-speech WAV, heard back), hears "yes" and drives to the cafeteria."""

from __future__ import annotations

from pathlib import Path

import pytest

from cyborg.hearing.audio import read_wav
from cyborg.hearing.grammar import build_grammar
from cyborg.hearing.module import KIND, SpeechInput, SpeechInputSettings
from cyborg.hearing.recogniser import Recogniser
from cyborg.hearing.synth import VOICES, as_heard, synthesise
from cyborg.modules.speech import TextToSpeech
from cyborg.transport.clock import VirtualClock
from tests.navigation.test_module import (  # the default robot and a user, as in the navigation tests
    OFFER,
    Cyborg,
)


@pytest.mark.slow  # about 15 s: real speech synthesis and recognition of every turn
def test_where_is_the_cafeteria_then_yes_drives_there(tmp_path: Path) -> None:
    clock = VirtualClock(speed=10.0)  # time runs while espeak-ng writes and pocketsphinx decodes
    cyborg = Cyborg(clock, tmp_path / "data")
    tts = cyborg.robot.components["cyborg_tts"]
    assert isinstance(tts, TextToSpeech) and tts.espeak, (
        "espeak-ng must be installed (scripts/install-system-deps)"
    )
    cyborg.nav.answer_timeout = (
        200.0  # 20 s of real time for the person to hear the offer and answer, on a busy machine
    )
    tts.wav_dir = tmp_path / "said"
    tts.wav_dir.mkdir()
    ears = KIND.build(  # built as the robot builds its modules: it hears what they listen for
        cyborg.transport.node("cyborg_speech_input"),
        SpeechInputSettings(db=str(cyborg.nav.db.path)),
        cyborg.robot.place,
    )
    assert isinstance(ears, SpeechInput)
    assert ears.recogniser.name == "whisper", "the Whisper model must be installed (scripts/setup)"
    person = Recogniser(min_confidence=0.0)  # a person who knows what the robot may offer
    person.use(build_grammar([], [], [OFFER, "all right maybe another time"], person.known_word))

    async def main() -> None:
        await cyborg.settle()
        [question] = await ears.listen_to(synthesise("where is the cafeteria", VOICES[3]))
        assert question.accepted and question.text == "where is the cafeteria"
        await cyborg.until(lambda: bool(list(tts.wav_dir.glob("*.wav"))), 30.0, "the offer's WAV")  # type: ignore[union-attr]
        await clock.sleep(3.0)  # 0.3 s: espeak-ng finishes the file
        [wav] = tts.wav_dir.glob("*.wav")  # type: ignore[union-attr]
        offer = person.decode(as_heard(read_wav(wav)))
        assert offer.text == "i think i know where that is would you like me to show you"
        [answer] = await ears.listen_to(synthesise("yes", VOICES[0]))
        assert answer.accepted and answer.text == "yes"
        await cyborg.until(lambda: cyborg.at("cafeteria"), 300.0, "the robot at the cafeteria")

    try:
        clock.run(main())
    finally:
        ears.close()
        cyborg.robot.close()
        clock.close()
    assert cyborg.sentences()[0] == OFFER
