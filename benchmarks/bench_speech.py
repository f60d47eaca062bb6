"""Speech recognition: accuracy on synthesised speech and end-of-speech -> /text_from_speech latency.

Usage: .venv/bin/python benchmarks/bench_speech.py

Every utterance is synthesised now (espeak-ng and flite voices at several rates, quiet and noisy);
in-grammar ones count when the published text gives the event the typed sentence gives,
out-of-grammar ones when nothing is published. Two sets of sentences: the tuning set (the
recogniser's language-model weights were chosen on it) and a held-out set of other sentences,
never looked at while tuning; both are reported, and together.
The ears hear what the packaged robot's modules listen for (handed over as the composition root does). The latency is measured inside the module, from
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

from cyborg.app.config import load_config, packaged_config
from cyborg.app.context import heard_by
from cyborg.app.registry import module_kinds
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
HELD_OUT_IN = [
    "where can i find the elevator",
    "go to the information desk",
    "what do you think of the canteen",
    "hi there",
    "no thanks",
    "where is entrance 2",
    "move to el5",
    "yeah",
    "good evening",
    "where is the main entrance",
]
HELD_OUT_OUT = [
    "what time is it",
    "turn off the lights",
    "where is the toilet",
    "open the door",
    "i need a coffee",
    "good night everyone",
    "play some music",
    "how old are you",
    "the elevator is broken",
    "can you help me",
]
SETS = {"tuning": (IN_GRAMMAR, OUT_OF_GRAMMAR), "held-out": (HELD_OUT_IN, HELD_OUT_OUT)}
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
    listening = heard_by(load_config(packaged_config("cyborg.yaml")), module_kinds())()
    ears = SpeechInput(
        transport.node("cyborg_speech_input"), NavigationDatabase(db.path), listening=listening
    )
    published: list[str] = []
    transport.node("listener").subscribe(
        topics.TEXT_FROM_SPEECH, String, lambda m, i: published.append(m.data)
    )
    # (set, in grammar, right, sentence, voice, heard)
    results: list[tuple[str, bool, bool, str, str, str]] = []
    scored: list[tuple[bool, bool, float]] = []  # (in grammar, accepted with the right event, confidence)

    async def run() -> None:
        for name, (inside, outside) in SETS.items():
            for noise in NOISES:
                for voice in VOICES:
                    for sentence in inside + outside:
                        published.clear()
                        heard = await ears.listen_to(synthesise(sentence, voice, noise=noise))
                        await clock.sleep(0)
                        texts = list(published)
                        if sentence in inside:
                            right = len(texts) == 1 and event_of(texts[0], db) == event_of(sentence, db)
                        else:
                            right = not texts
                        for h in heard:
                            intended = (
                                sentence in inside
                                and h.accepted
                                and event_of(h.text, db) == event_of(sentence, db)
                            )
                            scored.append(
                                (
                                    sentence in inside,
                                    intended or (sentence not in inside and not h.accepted),
                                    h.confidence,
                                )
                            )
                        shown = "; ".join(f"{h.raw or '-'} ({h.reason or 'accepted'})" for h in heard)
                        results.append(
                            (name, sentence in inside, right, sentence, f"{voice} noise {noise:g}", shown)
                        )

    try:
        clock.run(run())
    finally:
        ears.close()
        clock.close()
    latencies = [s * 1000 for s in ears.latencies]
    print(machine_line())
    print(f"utterances: {len(results)}")
    for name in [*SETS, "all"]:
        chosen = [r for r in results if name in (r[0], "all")]
        inside = [r for r in chosen if r[1]]
        outside = [r for r in chosen if not r[1]]
        ok_in, ok_out = sum(r[2] for r in inside), sum(r[2] for r in outside)
        print(
            f"{name}: in grammar, intended event {ok_in}/{len(inside)} = {100 * ok_in / len(inside):.1f} % "
            f"(target >= 95 %); out of grammar, rejected {ok_out}/{len(outside)} = "
            f"{100 * ok_out / len(outside):.1f} % (target >= 90 %)"
        )
    print(
        f"latency end-pointer -> topic (last {len(latencies)}): p50 {percentile(latencies, 50):.0f} ms, p95 {percentile(latencies, 95):.0f} ms (target p95 <= 300 ms)"
    )
    print(
        "min_confidence sweep (same decodes, both sets): threshold, in-grammar right %, out-of-grammar rejected %"
    )
    n_in, n_out = sum(1 for s in scored if s[0]), sum(1 for s in scored if not s[0])
    for threshold in (0.0, 0.01, 0.02, 0.05, 0.1):
        ok_in = sum(1 for i, right, c in scored if i and right and c >= threshold)
        ok_out = sum(1 for i, right, c in scored if not i and (right or c < threshold))
        print(f"  {threshold:.2f}: {100 * ok_in / n_in:.1f} %, {100 * ok_out / n_out:.1f} %")
    wrong = Counter(r[3] for r in results if not r[2])
    print("wrong most often:", ", ".join(f"{s!r} x{n}" for s, n in wrong.most_common(10)))
    for r in results:
        if not r[2]:
            print(f"  wrong ({r[0]}):", r[3], "|", r[4], "->", r[5])


if __name__ == "__main__":
    main()
