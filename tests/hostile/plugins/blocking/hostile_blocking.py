"""A student's module that does blocking work in its speech callback (a synchronous request, say)."""

import time

from cyborg.modules.behaviour import BehaviourModule
from cyborg.modules.kind import ModuleKind, ModuleSettings
from cyborg.transport.base import MessageInfo, Node


class BlockingSettings(ModuleSettings):
    """Blocks for a few seconds on every sentence it hears."""

    seconds: float = 3.0


class Blocking(BehaviourModule):
    def __init__(self, node: Node, settings: BlockingSettings) -> None:
        super().__init__(node)
        self.seconds = settings.seconds
        self.on_speech_text(self.heard)

    def heard(self, text: str, info: MessageInfo) -> None:
        time.sleep(self.seconds)  # the mistake: this stops the whole in-process robot


KIND = ModuleKind(BlockingSettings, lambda node, settings, context: Blocking(node, settings))
