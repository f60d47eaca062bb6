"""What a subscriber believes of a message from the graph: who sent it, and how long it may be.

The graph is open (ROS 1 and ROS 2 without SROS2): any node may publish on any topic, with any
length. These small guards sit in the callbacks that take input from it, and say so once per
sender in the log instead of once per message:

- :class:`OnlyFrom` takes messages from one node only (the state changes of the controller's
  node; the text-to-speech's sentences from its gatekeeper). Over ROS 2 the sender is the
  publishing node as the graph names it; over ROS 1 it is the caller id the publisher declares
  itself, which a stranger can fake (docs/security.md);
- :class:`TextLimit` refuses a text over :data:`~cyborg.limits.MAX_TEXT_LENGTH`, the API's limit,
  so a megabyte "sentence" on a topic costs no more than one the API refuses.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass, field

from cyborg.limits import MAX_TEXT_LENGTH
from cyborg.transport.base import normalize_node_name

__all__ = ["OnlyFrom", "TextLimit"]

log = logging.getLogger(__name__)


@dataclass
class OnlyFrom:
    """Accept messages on ``topic`` from the nodes ``allowed`` (names with or without the slash)."""

    allowed: str | tuple[str, ...]
    topic: str
    what: str = "messages"
    ignored: Counter[str] = field(default_factory=Counter)
    """Messages ignored, by sender."""

    def accepts(self, sender: str) -> bool:
        allowed = (self.allowed,) if isinstance(self.allowed, str) else self.allowed
        name = normalize_node_name(sender)
        if name in {normalize_node_name(a) for a in allowed}:
            return True
        if not self.ignored[name]:
            log.warning(
                "ignored %s on %s from %s: they are taken from %s only; something else publishes on "
                "this robot's graph (another robot, a test, a stranger; further ones from it are "
                "counted, not logged); fix: give each robot a graph of its own (docs/security.md)",
                self.what,
                self.topic,
                name or "an unknown node",
                " and ".join(sorted(normalize_node_name(a) for a in allowed)),
            )
        self.ignored[name] += 1
        return False


@dataclass
class TextLimit:
    """Accept texts on ``topic`` of at most ``limit`` characters."""

    topic: str
    limit: int = MAX_TEXT_LENGTH
    refused: Counter[str] = field(default_factory=Counter)
    """Texts refused, by sender."""

    def accepts(self, text: str, sender: str) -> bool:
        if len(text) <= self.limit:
            return True
        name = normalize_node_name(sender)
        if not self.refused[name]:
            log.warning(
                "ignored a text of %d characters on %s from %s, over the limit of %d (%.60r...); "
                "further ones from it are counted, not logged; fix: send one sentence at a time",
                len(text),
                self.topic,
                name or "an unknown node",
                self.limit,
                text,
            )
        self.refused[name] += 1
        return False
