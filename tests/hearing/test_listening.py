"""The ears hear what the robot's modules declare they listen for, handed over by the composition root."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import Field

from cyborg.app.config import parse_config
from cyborg.app.context import BuildContext
from cyborg.app.parts import build_part
from cyborg.app.registry import module_kinds
from cyborg.app.robot import build_robot
from cyborg.hearing.module import SpeechInput
from cyborg.modules import ModuleKind, ModuleSettings
from cyborg.transport.base import Node
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport

ROBOT = """
initial: idle
timeouts: {connect: 1.0, preempt: 1.0}
states:
  idle: {action: cyborg_idle/idle, transitions: {conversation_interest: conversation, aborted: idle}}
  conversation: {action: cyborg_conversation/conversation, transitions: {succeeded: idle, aborted: idle}}
modules:
  cyborg_idle: {kind: idle}
  cyborg_conversation: {kind: conversation}
  porter: {kind: porter}
  ears: {kind: speech_input, db: DB}
"""


class PorterSettings(ModuleSettings):
    """Carries luggage to a place, and opens doors."""

    action: str = Field("porter/carry", description="action server")

    def listens_for(self) -> tuple[str, ...]:
        return ("Open the pod bay doors", "carry my bag to")

    def listens_for_places(self) -> tuple[str, ...]:
        return ("carry my bag to",)


class Porter:
    def __init__(self, node: Node) -> None:
        self.node = node

    def close(self) -> None:
        pass


PORTER: ModuleKind[Any] = ModuleKind(PorterSettings, lambda node, settings, context: Porter(node))


def test_the_ears_hear_every_configured_modules_phrases_and_places_after_theirs(tmp_path: Path) -> None:
    config = parse_config(ROBOT.replace("DB", str(tmp_path / "nav.db")), source="robot.yaml")
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    robot = build_robot(config, transport, data_dir=tmp_path, kinds=module_kinds({"porter": PORTER}))
    try:
        ears = robot.components["ears"]
        assert isinstance(ears, SpeechInput)
        grammar = ears.recogniser.grammar
        assert grammar is not None
        assert grammar.holds("open the pod bay doors")  # the porter's phrase
        assert grammar.holds("carry my bag to the cafeteria")  # a place of the database after it
        assert grammar.holds("hello there")  # the conversation module's greetings
        assert grammar.holds("yes") and grammar.holds("no")  # answers, always
        assert not grammar.holds("where is the cafeteria")  # no navigation module here
        assert not grammar.holds("open the pod bay doors cafeteria")
    finally:
        robot.close()
        clock.close()


def test_a_speech_input_node_of_its_own_hears_the_other_modules_too(tmp_path: Path) -> None:
    config = parse_config(ROBOT.replace("DB", str(tmp_path / "nav.db")), source="robot.yaml")
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    part = build_part(
        "ears", config, transport, BuildContext(data_dir=tmp_path), kinds=module_kinds({"porter": PORTER})
    )
    try:
        [ears] = part.components
        assert isinstance(ears, SpeechInput) and ears.recogniser.grammar is not None
        assert ears.recogniser.grammar.holds("carry my bag to the lift")
    finally:
        part.close()
        clock.close()
