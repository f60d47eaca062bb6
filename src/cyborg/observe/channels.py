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

import math
from typing import Any

FORMAT = "cyborg-recording"
"""The ``format`` key of the ``cyborg`` metadata record: what tells our recordings from others."""
FORMAT_VERSION = "2"
"""Bumped when a reader of an older recording would misread a newer one (2: the pose record is
the ``foxglove.PoseInFrame`` of ``/robot/pose``, in JSON, no longer a channel of its own)."""
READABLE_VERSIONS = ("1", "2")
"""The formats this code reads."""
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
    "pose": "/robot/pose",
    "problems": "/cyborg/problems",
}
"""Record type -> the JSON channel that holds it."""
OLD_POSE_TOPIC = "/cyborg/pose"
"""Format 1's pose records (``{x, y, theta}``), beside a protobuf ``foxglove.PoseInFrame``."""
TYPE_OF_TOPIC = {topic: kind for kind, topic in RECORD_TOPICS.items()} | {OLD_POSE_TOPIC: "pose"}
"""Channel -> the record type it holds (read with :func:`record_fields`)."""

EVENT_TOPIC = "/cyborg/events"
"""Every event sent to the controller, with its sender and source."""
INPUT_TOPIC = "/cyborg/inputs"
"""What came into the robot from outside (a script, the operator): what a re-run plays again."""
DIAGNOSTIC_TOPIC = "/cyborg/diagnostics"
"""Gatekeeper passes and drops, module crashes, the controller's counters, the modules muted in a
parallel state, other nodes' warnings and errors on a ROS graph (``kind``: passed, dropped,
crashed, controller, muted, rosout)."""
MARK_CHANNEL = "/cyborg/marks"
LOG_TOPIC = "/log"
POSE_TOPIC = RECORD_TOPICS["pose"]
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
    "pose": "foxglove.PoseInFrame",
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
    "pose": {
        "timestamp": {
            "type": "object",
            "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}},
        },
        "frame_id": _TEXT,
        "pose": {
            "type": "object",
            "properties": {
                "position": {"type": "object", "properties": {"x": _NUMBER, "y": _NUMBER, "z": _NUMBER}},
                "orientation": {
                    "type": "object",
                    "properties": {"x": _NUMBER, "y": _NUMBER, "z": _NUMBER, "w": _NUMBER},
                },
            },
        },
    },
    "problems": {"module": _TEXT, "open": {"type": "array"}},
}

OTHER_SCHEMAS: dict[str, tuple[str, dict[str, Any]]] = {
    EVENT_TOPIC: ("cyborg.Event", {"event": _TEXT, "sender": _TEXT, "source": _TEXT}),
    INPUT_TOPIC: ("cyborg.Input", {"topic": _TEXT, "sender": _TEXT, "data": {}}),
    DIAGNOSTIC_TOPIC: ("cyborg.Diagnostic", {"kind": _TEXT, "sender": _TEXT, "detail": {}}),
    MARK_CHANNEL: ("cyborg.Mark", {"note": _TEXT}),
}


def pose_message(fields: dict[str, Any], log_time_ns: int) -> dict[str, Any]:
    """A pose record's fields (``x``, ``y``, ``theta``) as a ``foxglove.PoseInFrame`` (its JSON form):
    one message that Foxglove's 3D panel draws and :func:`record_fields` reads back exactly."""
    half = float(fields["theta"]) / 2.0
    sec, nsec = divmod(log_time_ns, 1_000_000_000)
    return {
        "timestamp": {"sec": sec, "nsec": nsec},
        "frame_id": FRAME,
        "pose": {
            "position": {"x": fields["x"], "y": fields["y"], "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(half), "w": math.cos(half)},
        },
    }


def record_fields(kind: str, message: dict[str, Any]) -> dict[str, Any]:
    """A record's fields from its channel's message (decoded JSON). The pose comes back as the
    transcript has it: ``theta`` was rounded to 1 mrad, so the quaternion gives it back exactly."""
    if kind != "pose" or "pose" not in message:
        return message
    pose = message["pose"]
    orientation = pose["orientation"]
    theta = round(2.0 * math.atan2(orientation["z"], orientation["w"]), 3)
    return {"x": pose["position"]["x"], "y": pose["position"]["y"], "theta": theta}


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
