"""The thesis's four scenarios (10.2) run on the default robot in virtual time (embedded transport).

Each asserts the sequence of states and the sentences spoken (see expectations.py).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cyborg.app.config import load_config, packaged_config
from cyborg.observe.recorder import RecorderSettings
from cyborg.observe.recording import open_recording
from cyborg.sim.rerun import rerun
from cyborg.sim.scenario import run_scenario
from cyborg.sim.script import load_script
from cyborg.sim.transcript import in_transcript_order
from tests.scenarios.expectations import CHECKS, Record

HERE = Path(__file__).parent


def run(name: str, tmp_path: Path, *, record: Path | None = None) -> list[Record]:
    transcript = tmp_path / f"{name}.jsonl"
    with transcript.open("w") as out:
        records = run_scenario(
            load_config(packaged_config("cyborg.yaml")),
            load_script(HERE / f"{name}.yaml"),
            transcript=out,
            record=RecorderSettings(file=record) if record is not None else None,
        )
    lines = [json.loads(line) for line in transcript.read_text().splitlines()]
    # The transcript holds exactly what happened, each instant's records in a fixed order.
    assert lines == in_transcript_order(records)
    return records


@pytest.mark.parametrize("name", sorted(CHECKS))
def test_scenario(name: str, tmp_path: Path) -> None:
    """The scenario as the thesis tells it; and re-run from its recording (what it heard, at the
    nanosecond), it gives the same transcript byte for byte."""
    CHECKS[name](run(name, tmp_path, record=tmp_path / f"{name}.mcap"))
    again = rerun(open_recording(tmp_path / f"{name}.mcap"))
    assert again.skipped == []
    assert again.transcript == (tmp_path / f"{name}.jsonl").read_text(), "the re-run went another way"


def test_same_script_same_transcript(tmp_path: Path) -> None:
    (tmp_path / "1").mkdir()
    (tmp_path / "2").mkdir()
    assert run("scenario_d", tmp_path / "1") == run("scenario_d", tmp_path / "2")


def test_a_script_run_starts_fresh_whatever_its_data_folder_holds(tmp_path: Path) -> None:
    """Observation 0 of every scenario: neutral, with the emotion system on (it was left angry and off)."""
    from cyborg.emotion.model import PAD
    from cyborg.motivator.store import ControllerStore

    store = ControllerStore(tmp_path / "controller.db")
    store.save_emotion(PAD(-0.51, 0.59, 0.25), 0.0)
    store.set_emotion_enabled(False)
    store.save_saturations({"navigation_emotional": 1.0, "music_play": 1.0})
    store.close()
    script = load_script(HERE / "scenario_d.yaml").model_copy(update={"until": 12.0, "steps": []})
    records = run_scenario(load_config(packaged_config("cyborg.yaml")), script, data_dir=tmp_path)
    emotions = [r for r in records if r["type"] == "emotion"]
    assert (emotions[0]["t"], emotions[0]["emotion"], emotions[0]["pleasure"]) == (0.0, "neutral", 0.0)
    assert emotions[-1]["emotion"] == "unconcerned", "the idle module's boredom counts: the system is on"
    chosen = [r["event"] for r in records if r["type"] == "motivator" and r["status"] == "chosen"]
    assert chosen == ["navigation_emotional"], "saturations start at 0 too"


def test_a_question_asked_during_a_question_is_answered(tmp_path: Path) -> None:
    """What the navigation module hears while the robot asks its own question is acted on, and
    the robot returns to the conversation afterwards (the person is still there)."""
    script = tmp_path / "ask.yaml"
    script.write_text(
        "seed: 5\nuntil: 60\nsteps:\n"
        "  - {when: {type: emotion, emotion: unconcerned}, delay: 1, say: Hello}\n"
        "  - {when: {type: state, from: conversation}, delay: 2, say: where is the cafeteria}\n"
    )
    records = run_scenario(load_config(packaged_config("cyborg.yaml")), load_script(script))
    changes = [r for r in records if r["type"] == "state"]
    question = next(r for r in changes if r["from"] == "conversation")
    assert question["to"] in {"joke", "weather", "selfie", "follower", "simon_says"}
    heard = next(r["t"] for r in records if r["type"] == "heard" and "cafeteria" in r["text"])
    answer = next(r for r in changes if r["t"] >= heard)
    assert (answer["from"], answer["event"], answer["to"]) == (
        question["to"],
        "navigation_information",
        "navigation_talking",
    )
    offers = [r for r in records if r["type"] == "say" and "show you" in r["text"]]
    assert offers and offers[0]["t"] == pytest.approx(heard, abs=0.5)
    after = next(r for r in changes if r["t"] > answer["t"])
    assert (after["from"], after["to"]) == ("navigation_talking", "conversation")
