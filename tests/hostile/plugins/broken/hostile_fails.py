"""A student's module whose factory raises (it needs hardware that is not there)."""

from cyborg.modules.kind import BuildContext, Component, ModuleKind, ModuleSettings
from cyborg.transport.base import Node


class FailsSettings(ModuleSettings):
    """No settings."""


def build(node: Node, settings: FailsSettings, context: BuildContext) -> Component:
    raise ValueError("no serial port /dev/ttyUSB7")


KIND = ModuleKind(FailsSettings, build)
