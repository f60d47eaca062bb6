"""Writing a run's records as a transcript: JSON lines, the records of one instant in a fixed order.

Within one instant of virtual time, the records of a robot in one process come in the order its
event loop made them, while over ROS they come in the order the middleware delivered them: it
keeps the order of one topic's messages, not that of messages on different topics (a state change
and the emotion it caused). So that a transcript reads the same whichever way the robot ran, the
records of one instant are written state changes first, then the motivator's decisions, emotions,
what was said and heard, recognised speech and poses; each kind keeps its own order.
"""

from __future__ import annotations

import json
from typing import IO, Any

__all__ = ["INSTANT_ORDER", "TranscriptWriter", "in_transcript_order"]

INSTANT_ORDER = ("state", "motivator", "emotion", "say", "heard", "recognised", "pose")
"""How the records of one instant are ordered in a transcript (other kinds come last)."""

_RANK = {kind: rank for rank, kind in enumerate(INSTANT_ORDER)}


def _rank(record: dict[str, Any]) -> int:
    return _RANK.get(str(record.get("type")), len(_RANK))


def in_transcript_order(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``records`` (in the order they came) as a transcript holds them: each instant in order."""
    ordered: list[dict[str, Any]] = []
    start = 0
    for end in range(1, len(records) + 1):
        if end == len(records) or records[end].get("t") != records[start].get("t"):
            ordered.extend(sorted(records[start:end], key=_rank))
            start = end
    return ordered


class TranscriptWriter:
    """Writes records to ``out`` as JSON lines, an instant at a time (see the module doc).

    The records of the latest instant are held until a later one comes: call :meth:`close`
    (or :meth:`flush`) at the end, which writes them.
    """

    def __init__(self, out: IO[str]) -> None:
        self.out = out
        self._instant: list[dict[str, Any]] = []

    def write(self, record: dict[str, Any]) -> None:
        if self._instant and record.get("t") != self._instant[0].get("t"):
            self.flush()
        self._instant.append(record)

    def flush(self) -> None:
        """Write the held instant's records, in order, and flush the file."""
        instant, self._instant = self._instant, []
        for record in sorted(instant, key=_rank):
            self.out.write(json.dumps(record) + "\n")
        self.out.flush()

    def close(self) -> None:
        if not self.out.closed:
            self.flush()
