"""A scripted event source for demos: publishes configured events in turn, forever.

It stands in for the motivator and for people when a demo has neither. Registered as
the module kind ``event_script``.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

from cyborg.errors import InvalidValueError
from cyborg.modules.kind import BuildContext, KindSettings, ModuleKind, setting
from cyborg.transport import topics
from cyborg.transport.base import Node
from cyborg.transport.messages import String


@dataclass(frozen=True, kw_only=True)
class EventScriptSettings(KindSettings):
    """Publishes the listed events in turn, one every few seconds (a demo without people)."""

    events: list[str] = setting(  # noqa: RUF009 (a dataclasses.field)
        min_length=1, description="events to publish, in this order, round and round"
    )
    every: float = setting(10.0, gt=0, description="seconds between two events")

    def publishes(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(self.events))


class EventScript:
    """Publishes ``events`` one after the other, ``every`` seconds apart, starting after ``every``."""

    def __init__(self, node: Node, events: list[str], every: float) -> None:
        if every <= 0:
            raise InvalidValueError(f"every must be positive, got {every}")
        self.node = node
        self.events = list(events)
        self.every = every
        self._publisher = node.publisher(topics.REGISTER_EVENT, String)
        self._task: asyncio.Task[None] = node.clock.loop.create_task(self._run(), name=f"{node.name} script")

    def close(self) -> None:
        """Stop publishing."""
        self._task.cancel()

    async def _run(self) -> None:
        index = 0
        while self.events:
            await self.node.clock.sleep(self.every)
            self._publisher.publish(String(data=self.events[index % len(self.events)]))
            index += 1


def _build(node: Node, settings: EventScriptSettings, context: BuildContext) -> EventScript:
    return EventScript(node, settings.events, settings.every)


KIND = ModuleKind(EventScriptSettings, _build)
