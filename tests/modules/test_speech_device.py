"""Text-to-speech without a sound device: it says so once, with the fix, and goes on speaking.

What it says is still published on /cyborg_tts/spoken (the dashboard and the recording show it)
and takes as long as it would aloud; once the speaker is back, the robot speaks aloud again.
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from cyborg.modules import speech
from cyborg.modules.speech import TextToSpeech, probe_sound_output
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String
from cyborg.transport.topics import SPEECH_INPUT_TOPIC
from tests.support.sound import alsa_home


def test_the_probe_tells_a_working_sound_device_from_a_missing_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CONFIG_HOME", str(alsa_home(tmp_path / "ok", device=True)))
    assert probe_sound_output() is None
    monkeypatch.setenv("XDG_CONFIG_HOME", str(alsa_home(tmp_path / "gone", device=False)))
    problem = probe_sound_output()
    assert problem is not None and "no sound output" in problem and "fix: plug in the speaker" in problem


def test_without_a_sound_device_the_robot_warns_once_and_goes_on_speaking(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setenv("XDG_CONFIG_HOME", str(alsa_home(tmp_path / "gone", device=False)))
    monkeypatch.setattr(speech, "SOUND_RETRY", 0.3)
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    tts = TextToSpeech(transport.node("cyborg_tts"), play_audio=True)
    mouth = transport.node("mouth").publisher(SPEECH_INPUT_TOPIC, String)

    async def main() -> None:
        for text in ("Hello", "Follow me"):
            mouth.publish(String(text))
        while len(tts.spoken) < 2 or tts.queue:
            await clock.sleep(0.02)
        assert tts.sound_problem is not None
        monkeypatch.setenv("XDG_CONFIG_HOME", str(alsa_home(tmp_path / "back", device=True)))
        await clock.sleep(0.4)  # past SOUND_RETRY: the next sentence tries the speaker again
        mouth.publish(String("Here we are"))
        while len(tts.spoken) < 3:
            await clock.sleep(0.02)
        await clock.sleep(0.3)

    with caplog.at_level(logging.WARNING, logger="cyborg.modules.speech"):
        try:
            clock.run(main())
        finally:
            transport.shutdown()
            clock.close()
    assert list(tts.spoken) == ["Hello", "Follow me", "Here we are"]
    warnings = [r.getMessage() for r in caplog.records]
    cannot = [w for w in warnings if "cannot speak aloud" in w]
    assert len(cannot) == 1 and "fix: plug in the speaker" in cannot[0], warnings
    assert any("works again" in w for w in warnings), warnings
    assert tts.sound_problem is None
