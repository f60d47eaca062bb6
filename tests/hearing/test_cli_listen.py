"""cyborg listen --wav prints what it hears with its confidence, and says when no robot takes it."""

from __future__ import annotations

import wave
from pathlib import Path

from click.testing import CliRunner

from cyborg.cli import cli
from cyborg.hearing.synth import VOICES, synthesise


def test_listen_to_a_wav_prints_the_sentence_and_that_no_robot_took_it(tmp_path: Path) -> None:
    path = tmp_path / "question.wav"
    with wave.open(str(path), "wb") as wav:
        wav.setnchannels(1)
        wav.setsampwidth(2)
        wav.setframerate(16000)
        wav.writeframes(synthesise("where is the cafeteria", VOICES[3]))
    result = CliRunner().invoke(
        cli,
        [
            "listen",
            "--wav",
            str(path),
            "--db",
            str(tmp_path / "nav.db"),
            "--min-confidence",
            "0",
            "--url",
            "http://127.0.0.1:9",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "heard: where is the cafeteria  [confidence" in result.output
    assert "-> navigation_information: cafeteria" in result.output  # what the robot would do
    assert "not sent: no robot answers at http://127.0.0.1:9" in result.output


def test_listen_no_send_says_what_the_robot_would_do_and_what_it_rejects_without_a_robot(
    tmp_path: Path,
) -> None:
    path = tmp_path / "two.wav"
    quiet = bytes(32000)  # a second of silence between the sentences
    with wave.open(str(path), "wb") as wav:
        wav.setnchannels(1)
        wav.setsampwidth(2)
        wav.setframerate(16000)
        wav.writeframes(
            synthesise("take me to the canteen", VOICES[3])
            + quiet
            + synthesise("what is the weather like today", VOICES[3])
        )
    result = CliRunner().invoke(
        cli,
        [
            "listen",
            "--wav",
            str(path),
            "--db",
            str(tmp_path / "nav.db"),
            "--no-send",
            "--url",
            "http://127.0.0.1:9",
        ],
    )
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("heard:")]
    assert len(lines) == 2, result.output
    assert lines[0].startswith("heard: take me to the canteen  [confidence")
    assert lines[0].endswith("-> navigation_command: cafeteria")
    assert lines[1].startswith("heard: what is the weather like today") and lines[1].endswith(
        "rejected: not understood"
    )
    assert "not sent" not in result.output and "error" not in result.output.lower()


def test_listen_without_a_microphone_names_the_fix(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        cli, ["listen", "--db", str(tmp_path / "nav.db"), "--device", "no such microphone"]
    )
    assert result.exit_code == 1
    assert "no microphone to listen to" in result.output and "--wav FILE" in result.output


def test_sim_with_a_microphone_that_is_not_there_stops_with_the_fix(tmp_path: Path) -> None:
    from cyborg.app.config import packaged_config

    config = tmp_path / "robot.yaml"
    config.write_text(
        packaged_config("cyborg.yaml").read_text()
        + "\n  cyborg_speech_input: {kind: speech_input, source: microphone, device: no such microphone}\n"
    )
    result = CliRunner().invoke(
        cli,
        [
            "sim",
            "--config",
            str(config),
            "--mic",
            "--duration",
            "1",
            "--data-dir",
            str(tmp_path),
            "--port",
            "0",
        ],
    )
    assert result.exit_code == 1, result.output
    assert "no microphone to listen to" in result.output and "fix: plug one in" in result.output
    assert "Traceback" not in result.output
