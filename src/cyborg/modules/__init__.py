"""Everything a behaviour module needs, from one place.

A module is a class on :class:`BehaviourModule` that serves one or more states; its kind
(:class:`ModuleKind`: a :class:`ModuleSettings` model and a factory) lets the YAML's
``modules:`` section start it. :mod:`~cyborg.modules.behaviour` holds the class, and
:mod:`~cyborg.modules.kind` the kind and what a factory is given; :mod:`~cyborg.modules.settings`
the pydantic side of settings, :mod:`~cyborg.modules.plain_settings` settings as dataclasses
(the built-in thin kinds': a launched node makes them without pydantic). See ``docs/modules.md``
("your first module") and test it with :mod:`cyborg.testing`::

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

The built-in modules live beside it: :mod:`~cyborg.modules.idle` and
:mod:`~cyborg.modules.placeholder` (states with nothing to do, or not written yet),
:mod:`~cyborg.modules.conversation` (conversation and question), :mod:`~cyborg.modules.music`,
:mod:`~cyborg.modules.speech` (text-to-speech), :mod:`~cyborg.modules.event_script` (events on
a timetable) and :mod:`~cyborg.modules.gatekeeper` (the relay in front of an output, which lets
only the active state's module through). :mod:`~cyborg.modules.problems` tells the dashboard
what a module cannot fix itself (:class:`ProblemReporter`).

``Field`` and :class:`ModuleSettings` (pydantic's) are imported when first asked for: a node of
a built-in thin module, whose settings are a dataclass, loads no pydantic (issue 33).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from cyborg.modules.behaviour import Abort, BehaviourModule, GoalContext, Outcome
from cyborg.modules.kind import BuildContext, Component, ModuleKind
from cyborg.modules.problems import ProblemReporter
from cyborg.transport.base import MessageInfo, Node

if TYPE_CHECKING:
    from pydantic import Field

    from cyborg.modules.settings import ModuleSettings


def __getattr__(name: str) -> Any:
    if name == "Field":
        from pydantic import Field

        return Field
    if name == "ModuleSettings":
        from cyborg.modules.settings import ModuleSettings

        return ModuleSettings
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    "ProblemReporter",
]
