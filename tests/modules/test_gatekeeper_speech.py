"""Gatekeepers relay only the node the active state allows; speech is spoken one sentence at a time."""

from __future__ import annotations

import itertools

import pytest

from cyborg.app.config import parse_config
from cyborg.controller.runtime import Controller
from cyborg.modules.behaviour import BehaviourModule, GoalContext
from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.modules.speech import TextToSpeech, estimated_duration
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String
from cyborg.transport.topics import SPEECH_INPUT_TOPIC, SPOKEN_TOPIC

MACHINE = """
states:
  idle: {action: talker_a/run, transitions: {switch: other, aborted: idle}, resources: {speech: talker_a}}
  other: {action: talker_b/run, transitions: {switch: idle, aborted: idle}, resources: {speech: talker_b}}
"""


class Talker(BehaviourModule):
    """Tries to speak every second, in control or not."""

    def __init__(self, transport: EmbeddedTransport, name: str) -> None:
        super().__init__(transport.node(name))
        self.serve(f"{name}/run", self.run)
        self.node.clock.call_later(0.5, self.chatter)

    def chatter(self) -> None:
        self.say(f"{self.node.name} speaking")
        self.node.clock.call_later(1.0, self.chatter)

    async def run(self, ctx: GoalContext) -> None:
        await ctx.wait_forever()


def build(clock: VirtualClock) -> tuple[EmbeddedTransport, Gatekeeper, list[tuple[float, str]]]:
    transport = EmbeddedTransport(clock)
    gate = Gatekeeper(
        transport.node("speech_gate"),
        input_topic=topics.TEXT_TO_SPEECH,
        output_topic=SPEECH_INPUT_TOPIC,
        resource="speech",
    )
    heard: list[tuple[float, str]] = []

    def on_gated(m: String, info: MessageInfo) -> None:
        heard.append((clock.monotonic(), m.data))

    transport.node("listener").subscribe(SPEECH_INPUT_TOPIC, String, on_gated)
    return transport, gate, heard


def test_fails_closed_until_it_knows_the_resources(clock: VirtualClock) -> None:
    transport, gate, heard = build(clock)
    Talker(transport, "talker_a")
    clock.run(clock.sleep(3))
    assert heard == [] and gate.stats.dropped == 3


def test_only_the_module_in_control_gets_through(clock: VirtualClock) -> None:
    transport, gate, heard = build(clock)
    Talker(transport, "talker_a")
    Talker(transport, "talker_b")
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)
    switch = transport.node("switcher").publisher(topics.REGISTER_EVENT, String)
    controller.start()

    async def main() -> None:
        await clock.sleep(5.2)  # idle: talker_a holds speech
        switch.publish(String("switch"))
        await clock.sleep(5.0)  # other: talker_b holds speech

    clock.run(main())
    first = [text for t, text in heard if t < 5.2]
    second = [text for t, text in heard if t > 5.2]
    assert first and set(first) == {"talker_a speaking"}
    assert second and set(second) == {"talker_b speaking"}
    assert gate.stats.passed == len(heard)
    assert gate.stats.dropped_by_sender["talker_b"] >= 5
    assert gate.stats.dropped_by_sender["talker_a"] >= 4
    report = gate.report()
    assert report["held_by"] == "talker_b" and report["passed"] == len(heard)
    assert report["dropped_by_sender"] == dict(gate.stats.dropped_by_sender)


def test_tts_speaks_one_sentence_at_a_time_and_bounds_its_queue(clock: VirtualClock) -> None:
    transport = EmbeddedTransport(clock)
    tts = TextToSpeech(transport.node("cyborg_tts"), queue_size=3, play_audio=False)
    spoken: list[tuple[float, str]] = []
    transport.node("ear").subscribe(
        SPOKEN_TOPIC, String, lambda m, i: spoken.append((clock.monotonic(), m.data))
    )
    say = transport.node("mouth").publisher(SPEECH_INPUT_TOPIC, String)
    sentences = ["one two three", "four five", "six", "seven", "eight"]

    async def main() -> None:
        say.publish(String(sentences[0]))
        await clock.sleep(0.1)  # the first sentence is being spoken now
        for sentence in sentences[1:]:
            say.publish(String(sentence))
        await clock.sleep(30)

    clock.run(main())
    # "one two three" is taken at once; the queue of 3 keeps the newest three of the other four
    assert [text for _, text in spoken] == ["one two three", "six", "seven", "eight"]
    assert tts.dropped == 1
    gaps = [b[0] - a[0] for a, b in itertools.pairwise(spoken)]
    assert gaps[0] == pytest.approx(estimated_duration("one two three"), abs=1e-9)  # on the ns grid


def test_tts_speaks_only_what_its_gatekeeper_passed_and_no_text_over_the_limit(clock: VirtualClock) -> None:
    transport = EmbeddedTransport(clock)
    tts = TextToSpeech(
        transport.node("cyborg_tts"), play_audio=False, speak_from=("cyborg_speech_gatekeeper",)
    )
    gate = transport.node("cyborg_speech_gatekeeper").publisher(SPEECH_INPUT_TOPIC, String)
    stranger = transport.node("stranger").publisher(SPEECH_INPUT_TOPIC, String)

    async def main() -> None:
        stranger.publish(String("the stranger speaks through the robot"))
        gate.publish(String("x" * 2_001))
        gate.publish(String("hello"))
        await clock.sleep(5)

    clock.run(main())
    assert list(tts.spoken) == ["hello"]
    assert tts.senders is not None and tts.senders.ignored["stranger"] == 1
    assert tts.too_long.refused["cyborg_speech_gatekeeper"] == 1
