"""Everything a behaviour module needs, from one place.

A module is a class on :class:`BehaviourModule` that serves one or more states; its kind
(:class:`ModuleKind`: a :class:`ModuleSettings` model and a factory) lets the YAML's
``modules:`` section start it. See ``docs/modules.md`` ("your first module") and test it with
:mod:`cyborg.testing`::

    from cyborg.modules import BehaviourModule, Field, GoalContext, ModuleKind, ModuleSettings

    class GreeterSettings(ModuleSettings):
        \"\"\"Answers good morning.\"\"\"
        reply: str = Field("Good morning to you too!", description="what it answers")

    class Greeter(BehaviourModule):
        def __init__(self, node, settings):
            super().__init__(node)
            self.settings = settings
            self.serve("greeter/greet", self.greet)
            self.on_speech_text(self.heard)

        def heard(self, text, info):
            if "good morning" in text.lower():
                self.publish_event("greeting_heard")

        async def greet(self, ctx: GoalContext) -> None:
            self.say(self.settings.reply)
            await ctx.sleep(3)

    KIND = ModuleKind(GreeterSettings, lambda node, settings, context: Greeter(node, settings))
"""

from pydantic import Field

from cyborg.modules.behaviour import Abort, BehaviourModule, GoalContext, Outcome
from cyborg.modules.kind import BuildContext, Component, ModuleKind, ModuleSettings
from cyborg.transport.base import MessageInfo, Node

__all__ = [
    "Abort",
    "BehaviourModule",
    "BuildContext",
    "Component",
    "Field",
    "GoalContext",
    "MessageInfo",
    "ModuleKind",
    "ModuleSettings",
    "Node",
    "Outcome",
]
