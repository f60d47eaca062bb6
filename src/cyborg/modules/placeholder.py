"""Placeholder behaviour modules: configured from YAML, no code needed.

A placeholder serves one state: it may say a sentence, stays in control for a
while (or until preempted when no duration is given) and then succeeds. The
demo modules and the thesis's joke/weather/selfie/follower/Simon-says states
are placeholders; a student replaces one with a real module by starting a node
that offers the same action server.
"""

from __future__ import annotations

from dataclasses import dataclass

from cyborg.modules.helper import BehaviourModule, GoalContext
from cyborg.transport.base import Node


@dataclass(frozen=True)
class PlaceholderSpec:
    """What a placeholder does when its state becomes active."""

    action: str
    say: str = ""
    duration: float | None = None
    emotion: tuple[float, float, float] | None = None
    honour_cancel: bool = True


class PlaceholderModule(BehaviourModule):
    """Serves one or more placeholder states from one node."""

    def __init__(self, node: Node, specs: list[PlaceholderSpec]) -> None:
        super().__init__(node)
        self.specs = {spec.action: spec for spec in specs}
        for spec in specs:
            self.serve(spec.action, self._make_execute(spec), honour_cancel=spec.honour_cancel)

    def _make_execute(self, spec: PlaceholderSpec):  # type: ignore[no-untyped-def]
        async def execute(ctx: GoalContext) -> None:
            if spec.emotion is not None:
                self.send_emotion(*spec.emotion)
            if spec.say:
                self.say(spec.say)
            if spec.duration is None:
                await ctx.wait_forever()
            else:
                await ctx.sleep(spec.duration)

        return execute
