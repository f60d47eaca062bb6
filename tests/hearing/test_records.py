"""What the speech input decodes reaches the dashboard's records: text, confidence, and whether it was believed."""

from __future__ import annotations

from pathlib import Path

from cyborg.hearing.module import SpeechInput
from cyborg.hearing.recogniser import Recogniser
from cyborg.hearing.synth import VOICES, synthesise
from cyborg.modules.kind import Listening
from cyborg.navigation.database import NavigationDatabase
from cyborg.observe.records import Record, RecordStream
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport


def test_believed_and_rejected_sentences_become_records(tmp_path: Path, listening: Listening) -> None:
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    records: list[Record] = []
    RecordStream(transport.node("records")).listeners.append(records.append)
    ears = SpeechInput(
        transport.node("ears"),
        NavigationDatabase(tmp_path / "nav.db"),
        recogniser=Recogniser(min_confidence=0.0, place_doubt=0.0),  # a place believed, not asked about
        listening=listening,
    )

    async def main() -> None:
        await ears.listen_to(synthesise("where is the cafeteria", VOICES[3]))
        ears.recogniser.min_confidence = 1.01  # nothing is believed now
        await ears.listen_to(synthesise("where is the cafeteria", VOICES[3]))
        await clock.sleep(0.05)

    try:
        clock.run(main())
    finally:
        ears.close()
        clock.close()
    recognised = [r for r in records if r["type"] == "recognised"]
    assert [(r["text"], r["accepted"]) for r in recognised] == [
        ("where is the cafeteria", True),
        ("where is the cafeteria", False),
    ]
    assert all(0.0 <= r["confidence"] <= 1.0 for r in recognised)
    assert [r["text"] for r in records if r["type"] == "heard"] == ["where is the cafeteria"]
