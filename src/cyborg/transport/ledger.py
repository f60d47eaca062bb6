"""What a process sent and received, channel by channel: the ledger lockstep time balances.

A channel is what is counted: a topic, or one leg of a service call or action goal
(``/name#goal``, ``#accept``, ``#result``, ``#cancel``, ``#text``, ``#request``, ``#response``).
A *broadcast* channel reaches each listener (a topic: every subscription); a *unicast* one
reaches one (an action goal reaches its server, a result its client). The transports count on
the clock's :class:`Ledger` (:attr:`cyborg.transport.clock.Clock.ledger`) when the time is
lockstep time (:mod:`cyborg.transport.lockstep`).
"""

from __future__ import annotations

import threading
from collections import Counter
from enum import StrEnum
from typing import Any

__all__ = ["Channel", "Ledger"]


class Channel(StrEnum):
    """How many copies of one message the listeners of a channel receive."""

    BROADCAST = "b"  # one per listener (a topic's subscriptions)
    UNICAST = "u"  # one, when anyone listens (a goal to its server, a result to its client)


class Ledger:
    """What this process sent and received on each channel, and on which channels it listens.

    Called from the loop (and, for ``sent``, from any thread): counts only grow. The lockstep
    clock reads the changes since its last report (:meth:`take_changes`).
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._sent: Counter[str] = Counter()
        self._received: Counter[str] = Counter()
        self._listening: dict[str, tuple[int, Channel]] = {}
        self._changed_listening: set[str] = set()
        self._ignored: set[str] = set()

    def ignore(self, channel: str) -> None:
        """Count nothing on ``channel``: what arrives there is no step of the run (the ROS log,
        which every node publishes outside the transport). Call it before subscribing."""
        with self._lock:
            self._ignored.add(channel)

    def sent(self, channel: str, count: int = 1) -> None:
        with self._lock:
            self._sent[channel] += count

    def received(self, channel: str, count: int = 1) -> None:
        with self._lock:
            if channel not in self._ignored:
                self._received[channel] += count

    def listen(self, channel: str, kind: Channel = Channel.BROADCAST) -> None:
        """One more endpoint of this process receives ``channel`` (a subscription, a server)."""
        with self._lock:
            if channel in self._ignored:
                return
            count, _ = self._listening.get(channel, (0, kind))
            self._listening[channel] = (count + 1, kind)
            self._changed_listening.add(channel)

    def unlisten(self, channel: str) -> None:
        with self._lock:
            if channel in self._ignored:
                return
            count, kind = self._listening.get(channel, (0, Channel.BROADCAST))
            self._listening[channel] = (max(0, count - 1), kind)
            self._changed_listening.add(channel)

    def take_changes(self) -> dict[str, Any] | None:
        """The counts since the last call (None when nothing changed)."""
        with self._lock:
            if not (self._sent or self._received or self._changed_listening):
                return None
            changes: dict[str, Any] = {
                "sent": dict(self._sent),
                "recv": dict(self._received),
                "listen": {
                    channel: [self._listening[channel][0], self._listening[channel][1].value]
                    for channel in self._changed_listening
                },
            }
            self._sent.clear()
            self._received.clear()
            self._changed_listening.clear()
            return changes
