"""The idle module (thesis 9.1): the initial state, slowly getting bored.

While its state is active it sends a small negative PAD change every
``interval`` seconds (boredom), and stops the moment the controller preempts.
Registered as the module kind ``idle``.
"""

from __future__ import annotations

from dataclasses import dataclass

from cyborg.modules.behaviour import BehaviourModule, GoalContext
from cyborg.modules.kind import BuildContext, KindSettings, ModuleKind, setting
from cyborg.transport.base import Node

IDLE_ACTION = "cyborg_idle/idle"


@dataclass(frozen=True, kw_only=True)
class IdleSettings(KindSettings):
    """The idle state (thesis 9.1): waits, sending a little boredom now and then."""

    action: str = setting(IDLE_ACTION, description="action server of the idle state")
    interval: float = setting(8.0, gt=0, description="seconds between two boredom feedbacks")
    boredom: tuple[float, float, float] = setting(
        (-0.05, -0.05, -0.05), description="PAD change sent every interval"
    )


class IdleModule(BehaviourModule):
    """Serves the idle state: sends ``boredom`` every ``interval`` seconds until preempted."""

    def __init__(self, node: Node, settings: IdleSettings | None = None) -> None:
        super().__init__(node)
        self.settings = settings or IdleSettings()
        self.feedback_sent = 0
        self.serve(self.settings.action, self.idle)

    async def idle(self, ctx: GoalContext) -> None:
        while True:
            await ctx.sleep(self.settings.interval)
            self.send_emotion(*self.settings.boredom)
            self.feedback_sent += 1


def _build(node: Node, settings: IdleSettings, context: BuildContext) -> IdleModule:
    return IdleModule(node, settings)


KIND = ModuleKind(IdleSettings, _build)
