"""A student's module whose factory raises (it needs hardware that is not there)."""

from cyborg.modules.kind import ModuleKind, ModuleSettings


class FailsSettings(ModuleSettings):
    """No settings."""


def build(node: object, settings: FailsSettings, context: object) -> object:
    raise ValueError("no serial port /dev/ttyUSB7")


KIND = ModuleKind(FailsSettings, build)
