"""The idle module (thesis 9.1): the initial state, slowly getting bored.

While its state is active it sends a small negative PAD change every
``interval`` seconds (boredom), and stops the moment the controller preempts.
"""

from __future__ import annotations

from dataclasses import dataclass

from cyborg.modules.helper import BehaviourModule, GoalContext
from cyborg.transport.base import Node

IDLE_ACTION = "cyborg_idle/idle"


@dataclass(frozen=True)
class IdleSettings:
    interval: float = 8.0
    boredom: tuple[float, float, float] = (-0.05, -0.05, -0.05)


class IdleModule(BehaviourModule):
    def __init__(self, node: Node, settings: IdleSettings | None = None, action: str = IDLE_ACTION) -> None:
        super().__init__(node)
        if settings is not None and settings.interval <= 0:
            raise ValueError(f"idle interval must be positive, got {settings.interval}")
        self.settings = settings or IdleSettings()
        self.feedback_sent = 0
        self.serve(action, self.idle)

    async def idle(self, ctx: GoalContext) -> None:
        while True:
            await ctx.sleep(self.settings.interval)
            self.send_emotion(*self.settings.boredom)
            self.feedback_sent += 1
