"""Speech recognition (issue 15): accuracy on synthesised speech and end-of-speech -> /text_from_speech latency.

Usage: .venv/bin/python benchmarks/bench_speech.py

Every utterance is synthesised now (espeak-ng and flite voices at several rates, quiet and noisy);
in-grammar ones count when the published text gives the event the typed sentence gives,
out-of-grammar ones when nothing is published. The latency is measured inside the module, from
the moment the end-pointer closes an utterance to the text on the topic (decoding included); the
end-pointer itself waits for 0.3 s of silence before it closes one.
Targets: >= 95 % in-grammar give the intended event, >= 90 % out-of-grammar rejected, p95 <= 300 ms.
"""

from __future__ import annotations

import sys
import tempfile
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import machine_line, percentile

from cyborg.hearing.module import SpeechInput
from cyborg.hearing.synth import VOICES, synthesise
from cyborg.modules.conversation import is_greeting
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.keywords import detect_answer, detect_navigation
from cyborg.transport import topics
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String

IN_GRAMMAR = [
    "hello",
    "good morning",
    "what do you think of el6",
    "where is el6",
    "where is the cafeteria",
    "go to entrance 2",
    "where is the e16",
    "go to the lift",
    "where is the information desk",
    "yes",
    "no",
    "where is the waiting area",
]
OUT_OF_GRAMMAR = [
    "what is the weather like today",
    "nothing to see here",
    "i like turtles",
    "can you tell me a joke",
    "where is the library",
    "my name is anna",
    "see you later",
    "thank you very much",
    "the bus leaves at noon",
    "i forgot my keys at home",
]
NOISES = (30.0, 400.0)  # standard deviation of white noise, of 32768


def event_of(text: str, db: NavigationDatabase) -> str | None:
    if is_greeting(text):
        return "conversation_interest"
    found = detect_navigation(text, db.matcher()) or detect_answer(text)
    return f"{found.intent.value}:{found.location}" if found else None


def main() -> None:
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    folder = Path(tempfile.mkdtemp())
    db = NavigationDatabase(folder / "navigation.db")
    ears = SpeechInput(transport.node("cyborg_speech_input"), NavigationDatabase(db.path))
    published: list[str] = []
    transport.node("listener").subscribe(
        topics.TEXT_FROM_SPEECH, String, lambda m, i: published.append(m.data)
    )
    results: list[tuple[bool, bool, str, str, str]] = []  # (in grammar, right, sentence, voice, heard)
    scored: list[tuple[bool, bool, float]] = []  # (in grammar, the event is right, confidence) per utterance

    async def run() -> None:
        for noise in NOISES:
            for voice in VOICES:
                for sentence in IN_GRAMMAR + OUT_OF_GRAMMAR:
                    published.clear()
                    heard = await ears.listen_to(synthesise(sentence, voice, noise=noise))
                    await clock.sleep(0)
                    texts = list(published)
                    if sentence in IN_GRAMMAR:
                        right = len(texts) == 1 and event_of(texts[0], db) == event_of(sentence, db)
                    else:
                        right = not texts
                    for h in heard:
                        intended = sentence in IN_GRAMMAR and event_of(h.text, db) == event_of(sentence, db)
                        scored.append((sentence in IN_GRAMMAR, intended, h.confidence if h.raw else -1.0))
                    shown = "; ".join(
                        f"{h.raw} ({h.confidence:.2f}{'' if h.accepted else ' rejected'})" for h in heard
                    )
                    results.append(
                        (sentence in IN_GRAMMAR, right, sentence, f"{voice} noise {noise:g}", shown)
                    )

    try:
        clock.run(run())
    finally:
        ears.close()
        clock.close()
    inside = [r for r in results if r[0]]
    outside = [r for r in results if not r[0]]
    latencies = [s * 1000 for s in ears.latencies]
    print(machine_line())
    print(f"utterances: {len(results)} ({len(inside)} in grammar, {len(outside)} outside)")
    print(
        f"in grammar, intended event: {sum(r[1] for r in inside)}/{len(inside)} = {100 * sum(r[1] for r in inside) / len(inside):.1f} % (target >= 95 %)"
    )
    print(
        f"out of grammar, rejected: {sum(r[1] for r in outside)}/{len(outside)} = {100 * sum(r[1] for r in outside) / len(outside):.1f} % (target >= 90 %)"
    )
    print(
        f"latency end-pointer -> topic (last {len(latencies)}): p50 {percentile(latencies, 50):.0f} ms, p95 {percentile(latencies, 95):.0f} ms (target p95 <= 300 ms)"
    )
    print(
        "min_confidence sweep (same decodes): threshold, in-grammar intended event %, out-of-grammar rejected %"
    )
    for threshold in (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3):
        ok_in = sum(1 for i, right, c in scored if i and right and c >= threshold)
        ok_out = sum(1 for i, _, c in scored if not i and c < threshold)
        n_in, n_out = sum(1 for s in scored if s[0]), sum(1 for s in scored if not s[0])
        print(f"  {threshold:.2f}: {100 * ok_in / n_in:.1f} %, {100 * ok_out / n_out:.1f} %")
    wrong = Counter(r[2] for r in results if not r[1])
    print("wrong most often:", ", ".join(f"{s!r} x{n}" for s, n in wrong.most_common(8)))
    for r in results:
        if not r[1]:
            print("  wrong:", r[2], "|", r[3], "->", r[4])


if __name__ == "__main__":
    main()
