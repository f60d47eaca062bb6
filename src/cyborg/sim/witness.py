"""What happened to the things a scenario step waits for, though no transcript record shows it.

A failed step says what came instead; the :class:`Witness` adds why the expected thing may not
have come: an event the controller dropped (it is no transition of the active state), a message
a gatekeeper dropped (its sender holds no grant of the resource) and a module that crashed.
All of it is seen on any transport, in process or over ROS: the witness listens to the event
topic beside the controller and reads the transitions the controller shares, and gatekeepers
and modules report drops and crashes on their diagnostic topics (``topics.GATEKEEPER_DROPPED``,
``topics.MODULE_CRASHED``). None of it goes to the transcript.
"""

from __future__ import annotations

import json
from collections import deque
from dataclasses import dataclass
from typing import Any

from cyborg.observe.records import Record, readable_seconds, to_ns
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.messages import String

NOTES_KEPT = 200
"""Notes kept, the oldest dropped first (a step names those since it was armed)."""


@dataclass(frozen=True)
class Note:
    t_ns: int
    """Nanoseconds since the run started."""
    text: str

    @property
    def t(self) -> float:
        """Seconds since the run started, rounded to 1 ms (to print)."""
        return readable_seconds(self.t_ns)


class Witness:
    """Notes, with their time, what dropped or broke the things a script may wait for."""

    def __init__(self, node: Node, *, origin: float = 0.0) -> None:
        self.node = node
        self.origin = origin
        self.notes: deque[Note] = deque(maxlen=NOTES_KEPT)
        self.state: str | None = None  # the active state, as the last state record told it
        self._transitions: dict[str, list[str]] | None = None
        self._events: deque[tuple[int, str, str, str]] = deque(maxlen=NOTES_KEPT)
        """(time, event, sender, the state it was sent in), judged only when a failure is told."""
        node.subscribe(topics.REGISTER_EVENT, String, self._on_event, queue_size=1000)
        node.subscribe(topics.GATEKEEPER_DROPPED, String, self._on_drop, queue_size=1000)
        node.subscribe(topics.MODULE_CRASHED, String, self._on_crash, queue_size=100)

    def now_ns(self) -> int:
        return to_ns(self.node.clock.monotonic() - self.origin)

    def note(self, text: str) -> None:
        self.notes.append(Note(self.now_ns(), text))

    def since(self, t_ns: int) -> list[Note]:
        """The notes from ``t_ns`` on (nanoseconds since the run started), the dropped events among them.

        Only here, when a failure is told, are the controller's transitions read (a parameter,
        a blocking call over ROS): while the run goes on, the witness only writes events down,
        so it never holds up the loop that stamps the transcript's records."""
        dropped = [
            note
            for t_, name, sender, state in self._events
            if t_ >= t_ns
            if (note := self._dropped(t_, name, sender, state))
        ]
        return sorted(
            [*(note for note in self.notes if note.t_ns >= t_ns), *dropped], key=lambda note: note.t_ns
        )

    def on_record(self, record: Record) -> None:
        if record.get("type") == "state":
            self.state = str(record.get("to"))

    def _on_event(self, message: String, info: MessageInfo) -> None:
        if self.state is not None:
            self._events.append((self.now_ns(), message.data.strip(), info.sender, self.state))

    def _dropped(self, t_ns: int, name: str, sender: str, state: str) -> Note | None:
        transitions = self._transitions_of(state)
        if transitions is None or name in transitions:
            return None
        return Note(
            t_ns,
            f"event {name!r} from {sender} was dropped by the controller: it is no transition of "
            f"{state!r} (its events: {', '.join(transitions) or 'none'})",
        )

    def _transitions_of(self, state: str) -> list[str] | None:
        if self._transitions is None:
            try:
                shared = self.node.get_param(topics.TRANSITIONS_PARAM)
            except Exception:  # no parameter server at hand: no note, nothing else
                return None
            if not isinstance(shared, dict):
                return None
            self._transitions = {
                str(k): [str(e) for e in v] for k, v in shared.items() if isinstance(v, list)
            }
        return self._transitions.get(state)

    def _on_drop(self, message: String, info: MessageInfo) -> None:
        drop = _json(message)
        sender, resource = drop.get("sender"), drop.get("resource")
        self.note(
            f"{drop.get('gatekeeper', info.sender)} dropped {drop.get('message')!r} from {sender}: "
            f"{resource} is held by {drop.get('holder') or 'nobody'}; fix: grant it in the state, "
            f"resources: {{{resource}: {sender}}}"
        )

    def _on_crash(self, message: String, info: MessageInfo) -> None:
        crash = _json(message)
        self.note(
            f"{crash.get('module', info.sender)} crashed ({crash.get('error')}); its state "
            f"({crash.get('action')}) ended 'aborted'"
        )


def _json(message: String) -> dict[str, Any]:
    try:
        value = json.loads(message.data)
    except ValueError:
        return {}
    return value if isinstance(value, dict) else {}
