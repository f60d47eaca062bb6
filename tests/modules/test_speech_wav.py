"""Text-to-speech writes real speech with espeak-ng."""

from __future__ import annotations

import wave
from pathlib import Path

from cyborg.modules.speech import TextToSpeech
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String
from cyborg.transport.topics import SPEECH_INPUT_TOPIC


def test_sentences_become_wav_files(tmp_path: Path) -> None:
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    tts = TextToSpeech(transport.node("cyborg_tts"), play_audio=False, wav_dir=tmp_path)
    assert tts.espeak, "espeak-ng must be installed (scripts/install-system-deps)"
    mouth = transport.node("mouth").publisher(SPEECH_INPUT_TOPIC, String)

    async def main() -> None:
        mouth.publish(String("Human, this is the cafeteria"))
        while len(list(tmp_path.glob("*.wav"))) < 1 or not tts.spoken:
            await clock.sleep(0.05)
        await clock.sleep(0.5)

    try:
        clock.run(main())
    finally:
        clock.close()
    [path] = tmp_path.glob("*.wav")
    with wave.open(str(path)) as wav:
        seconds = wav.getnframes() / wav.getframerate()
    assert 1.0 < seconds < 5.0
    assert list(tts.spoken) == ["Human, this is the cafeteria"]
