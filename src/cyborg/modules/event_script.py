"""A scripted event source for demos: publishes configured events in turn, forever.

It stands in for the motivator and for people when a demo has neither.
"""

from __future__ import annotations

import asyncio

from cyborg.transport import topics
from cyborg.transport.base import Node
from cyborg.transport.messages import String


class EventScript:
    """Publishes ``events`` one after the other, ``every`` seconds apart, starting after ``every``."""

    def __init__(self, node: Node, events: list[str], every: float) -> None:
        if every <= 0:
            raise ValueError(f"every must be positive, got {every}")
        self.node = node
        self.events = list(events)
        self.every = every
        self._publisher = node.publisher(topics.REGISTER_EVENT, String)
        self._task: asyncio.Task[None] = node.clock.loop.create_task(self._run(), name=f"{node.name} script")

    async def _run(self) -> None:
        index = 0
        while self.events:
            await self.node.clock.sleep(self.every)
            self._publisher.publish(String(data=self.events[index % len(self.events)]))
            index += 1
