"""What a recording holds: its channels, their schemas, and how a record maps to a channel.

Shared by the writer (:mod:`~cyborg.observe.recorder`) and the readers
(:mod:`~cyborg.observe.recording`, replay, re-run, export). Each transcript record type has a JSON
channel whose message is the record without ``t``, ``t_ns`` and ``type`` (the message's log time
carries the time), so a recording gives back the transcript byte for byte. Beside them, Foxglove's
well-known schemas give Foxglove and Lichtblick their panels: ``foxglove.Log`` (speech, warnings,
marks), ``foxglove.PoseInFrame`` (the robot), ``foxglove.Grid`` (the map) and
``foxglove.SceneUpdate`` (the named places).
"""

from __future__ import annotations

from typing import Any

FORMAT = "cyborg-recording"
"""The ``format`` key of the ``cyborg`` metadata record: what tells our recordings from others."""
FORMAT_VERSION = "1"
"""Bumped when a reader of an older recording would misread a newer one."""
METADATA_NAME = "cyborg"
PROFILE = ""

RECORDER_STATUS_TOPIC = "/cyborg_recorder/status"
"""Where the recorder says what it records, or that it stopped (JSON in a std_msgs/String)."""
MARK_TOPIC = "/cyborg_recorder/mark"
"""A note to put into the recording (the dashboard's "mark" button)."""
FLUSH_TOPIC = "/cyborg_recorder/flush"
"""A request (its text an id) to write out what the recorder holds back, so that the file can be
read up to now (the live dashboard's look back); the status that follows carries the id as
``flushed``."""

RECORD_TOPICS: dict[str, str] = {
    "state": "/cyborg_controller/state_change",
    "emotion": "/cyborg_controller/emotional_state",
    "motivator": "/cyborg_controller/motivator_decision",
    "say": "/cyborg/speech/said",
    "heard": "/cyborg/speech/heard",
    "recognised": "/cyborg/speech/recognised",
    "pose": "/cyborg/pose",
    "problems": "/cyborg/problems",
}
"""Record type -> the JSON channel that holds it."""
TYPE_OF_TOPIC = {topic: kind for kind, topic in RECORD_TOPICS.items()}

EVENT_TOPIC = "/cyborg/events"
"""Every event sent to the controller, with its sender and source."""
INPUT_TOPIC = "/cyborg/inputs"
"""What came into the robot from outside (a script, the operator): what a re-run plays again."""
DIAGNOSTIC_TOPIC = "/cyborg/diagnostics"
"""Gatekeeper passes and drops, module crashes, the controller's counters, the modules muted in a
parallel state (``kind``: passed, dropped, crashed, controller, muted)."""
MARK_CHANNEL = "/cyborg/marks"
LOG_TOPIC = "/log"
POSE_TOPIC = "/robot/pose"
MAP_TOPIC = "/map"
PLACES_TOPIC = "/places"
FRAME = "map"

SCHEMA_NAMES: dict[str, str] = {
    "state": "cyborg.StateChange",
    "emotion": "cyborg.Emotion",
    "motivator": "cyborg.MotivatorDecision",
    "say": "cyborg.Said",
    "heard": "cyborg.Heard",
    "recognised": "cyborg.Recognised",
    "pose": "cyborg.Pose",
    "problems": "cyborg.Problems",
}

_TEXT = {"type": "string"}
_NUMBER = {"type": "number"}
_NAME = {"type": ["string", "null"]}

RECORD_SCHEMAS: dict[str, dict[str, Any]] = {
    "state": {
        "event": _TEXT,
        "from": _TEXT,
        "to": _TEXT,
    },
    "emotion": {"emotion": _TEXT, "pleasure": _NUMBER, "arousal": _NUMBER, "dominance": _NUMBER},
    "motivator": {
        "event": _NAME,
        "candidates": {"type": "array"},
        "reason": _TEXT,
        "status": _NAME,
        "state": _NAME,
    },
    "say": {"text": _TEXT},
    "heard": {"text": _TEXT},
    "recognised": {"text": _TEXT, "confidence": _NUMBER, "accepted": {"type": "boolean"}},
    "pose": {"x": _NUMBER, "y": _NUMBER, "theta": _NUMBER},
    "problems": {"module": _TEXT, "open": {"type": "array"}},
}

OTHER_SCHEMAS: dict[str, tuple[str, dict[str, Any]]] = {
    EVENT_TOPIC: ("cyborg.Event", {"event": _TEXT, "sender": _TEXT, "source": _TEXT}),
    INPUT_TOPIC: ("cyborg.Input", {"topic": _TEXT, "sender": _TEXT, "data": {}}),
    DIAGNOSTIC_TOPIC: ("cyborg.Diagnostic", {"kind": _TEXT, "sender": _TEXT, "detail": {}}),
    MARK_CHANNEL: ("cyborg.Mark", {"note": _TEXT}),
}


def json_schema(title: str, properties: dict[str, Any]) -> dict[str, Any]:
    """A JSON schema (draft 2020-12) of an object with ``properties``."""
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "type": "object",
        "properties": properties,
    }


SOURCES = {
    "cyborg_scenario": "script",
    "cyborg_api": "operator",
    "cyborg_tool": "operator",
    "cyborg_rerun": "script",
}
"""Sender node -> the source of an event (anything else: the motivator, speech or a module)."""


def source_of(sender: str, *, motivator: str = "cyborg_motivator") -> str:
    """Where an event came from: script, operator, motivator, speech or module."""
    if sender in SOURCES:
        return SOURCES[sender]
    if sender == motivator:
        return "motivator"
    if "speech" in sender or "listen" in sender:
        return "speech"
    return "module"


EXTERNAL_SENDERS = frozenset(SOURCES)
"""Nodes whose messages are inputs from outside the robot (a re-run plays them again)."""
