"""The controller's queue of events from the topic: bounded by size and by age, fair to senders.

Pure logic, no I/O: :class:`~cyborg.controller.runtime.Controller` offers each event from
``/cyborg_controller/register_event`` with its sender and the clock's time, and takes the next
one when it is free. A flood from one sender (a buggy module, a stranger on the graph) must not
make the robot deaf to a person:

- each sender has its own first-in-first-out line, and the lines take turns (round robin), so a
  person's event waits behind at most one event of each flooding sender, not behind the flood;
- when the queue is full, an event from a sender with fewer queued than the one with the most
  still gets in, and that one's oldest event is dropped instead (a flooder loses its own events,
  not a person's); the fullest sender's own newcomer is dropped;
- an event older than ``max_age`` when its turn comes is dropped as stale: after a minute of
  handovers it no longer means what its sender meant;
- a sender's last queued event, taken, supersedes the events of other senders that arrived
  before it and still wait (only a flooder's backlog lets a newer event's turn come first):
  handled after it, they would undo what it asked for with what was asked earlier. A flooder's
  event, with more of its own behind it, supersedes nothing, so two flooders cannot push a
  person's event out between them.

:class:`DropCounter` turns the drops into few log lines: the first drop of a burst, then one
summary per period naming who sent what was dropped.
"""

from __future__ import annotations

import enum
from collections import Counter, deque
from dataclasses import dataclass, field

from cyborg.errors import ConfigError

__all__ = ["DropCounter", "DropReason", "EventIntake", "QueuedEvent"]


@dataclass(frozen=True)
class QueuedEvent:
    """An event from the topic, waiting for the controller."""

    name: str
    sender: str
    received_at: float  # clock.monotonic() when it arrived
    order: int = 0  # when it arrived among everything the controller queues (its results too)


class DropReason(enum.StrEnum):
    """Why an event from the topic was not handled."""

    OVERFLOW = "overflow"  # the queue was full
    STALE = "stale"  # it waited longer than the queue's max_age
    SUPERSEDED = "superseded"  # a newer event of another sender was taken before it


class EventIntake:
    """Events from the topic: at most ``size`` queued, none older than ``max_age`` seconds when taken."""

    def __init__(self, size: int, max_age: float) -> None:
        if size < 1:
            raise ConfigError(f"an event queue of {size} events holds nothing; fix: give at least 1")
        self.size = size
        self.max_age = max_age
        self._lines: dict[str, deque[QueuedEvent]] = {}  # sender -> its events; dict order = turn order
        self._count = 0

    def __len__(self) -> int:
        return self._count

    def offer(self, event: QueuedEvent) -> QueuedEvent | None:
        """Queue ``event``; return the event dropped to make room (maybe ``event`` itself), or None."""
        dropped: QueuedEvent | None = None
        if self._count >= self.size:
            fullest = max(self._lines, key=lambda sender: len(self._lines[sender]))
            own = len(self._lines.get(event.sender, ()))
            if own >= len(self._lines[fullest]):
                return event  # the sender holds the most already: its newest waits no more than its oldest
            dropped = self._lines[fullest].popleft()
            self._forget_if_empty(fullest)
            self._count -= 1
        self._lines.setdefault(event.sender, deque()).append(event)
        self._count += 1
        return dropped

    def take(self, now: float) -> tuple[QueuedEvent | None, list[tuple[QueuedEvent, DropReason]]]:
        """The next event by turn, and the events dropped on the way to it (stale, superseded)."""
        dropped: list[tuple[QueuedEvent, DropReason]] = []
        while self._lines:
            sender = next(iter(self._lines))
            line = self._lines.pop(sender)
            event = line.popleft()
            self._count -= 1
            if line:
                self._lines[sender] = line  # to the back: the other senders' turns first
            if now - event.received_at > self.max_age:
                dropped.append((event, DropReason.STALE))
                continue
            for other in [] if line else list(self._lines):
                waiting = self._lines[other]
                while waiting and waiting[0].received_at < event.received_at:
                    dropped.append((waiting.popleft(), DropReason.SUPERSEDED))
                    self._count -= 1
                self._forget_if_empty(other)
            return event, dropped
        return None, dropped

    def next_order(self) -> int | None:
        """The arrival order of the event whose turn is next (None: nothing queued)."""
        for line in self._lines.values():
            return line[0].order
        return None

    def has(self, wanted: set[str]) -> bool:
        """Whether an event named one of ``wanted`` is queued."""
        return any(event.name in wanted for line in self._lines.values() for event in line)

    def _forget_if_empty(self, sender: str) -> None:
        if not self._lines[sender]:
            del self._lines[sender]


@dataclass
class DropCounter:
    """Drops in bursts: a line for the first of a burst, then one summary per ``period`` seconds."""

    period: float
    pending: Counter[DropReason] = field(default_factory=Counter)  # reason -> drops not yet reported
    senders: Counter[str] = field(default_factory=Counter)  # sender -> drops not yet reported
    in_burst: bool = False

    def note(self, reason: DropReason, sender: str) -> bool:
        """Count a drop; True when it starts a burst (log it now, then schedule :meth:`summary`)."""
        if not self.in_burst:
            self.in_burst = True
            return True
        self.pending[reason] += 1
        self.senders[sender] += 1
        return False

    def summary(self) -> str | None:
        """What was dropped since the last line (None: nothing; the burst is over)."""
        if not self.pending:
            self.in_burst = False
            return None
        total = sum(self.pending.values())
        reasons = ", ".join(f"{count} {reason.value}" for reason, count in sorted(self.pending.items()))
        senders = ", ".join(f"{sender} {count}" for sender, count in self.senders.most_common(3))
        more = len(self.senders) - 3
        self.pending.clear()
        self.senders.clear()
        return (
            f"dropped {total} more event(s) in the last {self.period:g} s ({reasons}); "
            f"sent by {senders}{f' and {more} more' if more > 0 else ''}"
        )
