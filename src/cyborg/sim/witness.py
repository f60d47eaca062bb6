"""What happened to the things a scenario step waits for, though no transcript record shows it.

A failed step says what came instead; the :class:`Witness` adds why the expected thing may not
have come: an event the controller dropped (it is no transition of the active state), a message
a gatekeeper dropped (its sender holds no grant of the resource) and a module that crashed.
Dropped events are seen on any transport (the witness listens to the event topic beside the
controller and reads the transitions the controller shares); gatekeeper drops and crashes only
in the robot's own process (:meth:`Witness.watch_gatekeepers`, :meth:`Witness.watch_crashes`).
None of it goes to the transcript.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.observe.records import Record
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.messages import Message, String

NOTES_KEPT = 200
"""Notes kept, the oldest dropped first (a step names those since it was armed)."""
CRASH_LOGGER = "cyborg.modules.behaviour"
"""The logger of the action server that runs a module's goals and logs a goal that raised."""


@dataclass(frozen=True)
class Note:
    t: float
    text: str


class _CrashHandler(logging.Handler):
    def __init__(self, witness: Witness) -> None:
        super().__init__(logging.ERROR)
        self.witness = witness

    def emit(self, record: logging.LogRecord) -> None:
        if "crashed" not in record.getMessage():
            return
        error = record.exc_info[1] if record.exc_info else None
        what = f"{type(error).__name__}: {error}" if error is not None else record.getMessage()
        name = record.args[0] if isinstance(record.args, tuple) and record.args else "a module"
        self.witness.note(f"{name} crashed ({what}); its state ended 'aborted'")


class Witness:
    """Notes, with their time, what dropped or broke the things a script may wait for."""

    def __init__(self, node: Node, *, origin: float = 0.0) -> None:
        self.node = node
        self.origin = origin
        self.notes: deque[Note] = deque(maxlen=NOTES_KEPT)
        self.state: str | None = None  # the active state, as the last state record told it
        self._transitions: dict[str, list[str]] | None = None
        self._crashes: _CrashHandler | None = None
        node.subscribe(topics.REGISTER_EVENT, String, self._on_event, queue_size=1000)

    def now(self) -> float:
        return round(self.node.clock.monotonic() - self.origin, 3)

    def note(self, text: str) -> None:
        self.notes.append(Note(self.now(), text))

    def since(self, t: float) -> list[Note]:
        """The notes from ``t`` on (seconds since the run started)."""
        return [note for note in self.notes if note.t >= t]

    def on_record(self, record: Record) -> None:
        if record.get("type") == "state":
            self.state = str(record.get("to"))

    def _on_event(self, message: String, info: MessageInfo) -> None:
        name, state = message.data.strip(), self.state
        if state is None:
            return
        transitions = self._transitions_of(state)
        if transitions is not None and name not in transitions:
            self.note(
                f"event {name!r} from {info.sender} was dropped by the controller: it is no "
                f"transition of {state!r} (its events: {', '.join(transitions) or 'none'})"
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

    def watch_gatekeepers(self, gatekeepers: Iterable[Gatekeeper]) -> None:
        """Note every message these gatekeepers drop (in the robot's own process)."""
        for gatekeeper in gatekeepers:
            gatekeeper.drop_listeners.append(self._dropped_by(gatekeeper))

    def _dropped_by(self, gatekeeper: Gatekeeper) -> _DropNote:
        return _DropNote(self, gatekeeper)

    def watch_crashes(self) -> None:
        """Note every module goal that raised (in this process), until :meth:`close`."""
        if self._crashes is None:
            self._crashes = _CrashHandler(self)
            logging.getLogger(CRASH_LOGGER).addHandler(self._crashes)

    def close(self) -> None:
        if self._crashes is not None:
            logging.getLogger(CRASH_LOGGER).removeHandler(self._crashes)
            self._crashes = None


@dataclass(frozen=True)
class _DropNote:
    witness: Witness
    gatekeeper: Gatekeeper

    def __call__(self, message: Message, info: MessageInfo) -> None:
        gate = self.gatekeeper
        what = repr(message.data) if isinstance(message, String) else type(message).__name__
        self.witness.note(
            f"{gate.node.name} dropped {what} from {info.sender}: {gate.resource} is held by "
            f"{gate.allowed or 'nobody'}; fix: grant it in the state, "
            f"resources: {{{gate.resource}: {info.sender}}}"
        )
