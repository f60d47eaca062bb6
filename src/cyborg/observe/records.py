"""Turn what happens on the robot's topics into plain records.

One record per observation, each a dict with ``t`` (seconds since the run started, on the
injected clock, rounded to 1 ms for people to read), ``t_ns`` (the same time in exact integer
nanoseconds: what code compares, orders and re-runs from) and ``type``: ``state``, ``emotion``, ``say``
(what was actually spoken, after the gatekeeper), ``heard``, ``recognised`` (each utterance
the speech input decoded: text, confidence, accepted), ``pose`` (at most
once per second while the pose changes) and ``motivator``. The scenario
transcript, the HTTP API and the dashboard all read these records.
"""

from __future__ import annotations

import asyncio
import json
import math
from collections.abc import Callable
from typing import Any

from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.guards import OnlyFrom, TextLimit
from cyborg.transport.messages import EmotionalState, PoseWithCovarianceStamped, String, SystemState
from cyborg.transport.topics import SPOKEN_TOPIC

Record = dict[str, Any]
MAX_PROBLEMS_TEXT = 65_536  # characters of a problems message read; a longer one is cut (and left out)
MAX_PROBLEMS = 20  # problems of one module kept in a record
POSE_INTERVAL_NS = 1_000_000_000
"""At most one pose record a second."""
NS_PER_S = 1_000_000_000


def to_ns(seconds: float) -> int:
    """Seconds (a clock reading) as integer nanoseconds."""
    return round(seconds * NS_PER_S)


def readable_seconds(t_ns: int) -> float:
    """Integer nanoseconds as the seconds a transcript shows, rounded to 1 ms (never compared)."""
    return round(t_ns / NS_PER_S, 3)


def yaw_of(z: float, w: float) -> float:
    return 2.0 * math.atan2(z, w)


class RecordStream:
    """Subscribes to the robot's topics through ``node`` and calls listeners with records."""

    def __init__(self, node: Node, *, origin: float | None = None) -> None:
        self.node = node
        self.origin = node.clock.monotonic() if origin is None else origin
        self.listeners: list[Callable[[Record], None]] = []
        self._last_pose_ns: int | None = None
        self._last_pose: tuple[float, float, float] | None = None
        self._pending_pose: tuple[float, float, float] | None = None
        self._pose_flush: asyncio.TimerHandle | None = None
        self._long_heard = TextLimit(topics.TEXT_FROM_SPEECH)
        self._foreign_states = OnlyFrom(topics.CONTROLLER_NODE, topics.STATE_CHANGE, "state changes")
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_state, queue_size=1000)
        node.subscribe(topics.EMOTIONAL_STATE, EmotionalState, self._on_emotion, queue_size=1000)
        node.subscribe(SPOKEN_TOPIC, String, self._on_spoken, queue_size=1000)
        node.subscribe(topics.TEXT_FROM_SPEECH, String, self._on_heard, queue_size=1000)
        node.subscribe(topics.SPEECH_HEARD, String, self._on_recognised, queue_size=1000)
        node.subscribe(topics.AMCL_POSE, PoseWithCovarianceStamped, self._on_pose, queue_size=10)
        node.subscribe(topics.MOTIVATOR_DECISION, String, self._on_decision, queue_size=1000)
        node.subscribe(topics.PROBLEMS, String, self._on_problems, queue_size=1000)

    def now_ns(self) -> int:
        """Nanoseconds since the run started, on the injected clock."""
        return to_ns(self.node.clock.monotonic() - self.origin)

    def now(self) -> float:
        """Seconds since the run started, rounded to 1 ms: for people, never for decisions."""
        return readable_seconds(self.now_ns())

    def emit(self, record_type: str, **fields: Any) -> None:
        t_ns = self.now_ns()
        record: Record = {"t": readable_seconds(t_ns), "t_ns": t_ns, "type": record_type, **fields}
        for listener in list(self.listeners):
            listener(record)

    def _on_problems(self, m: String, info: MessageInfo) -> None:
        """A module's open problems ({"module", "open": [{"key", "problem", "fix"}]}): a record
        of type "problems"; what is not that shape is left out (a stranger's message)."""
        try:
            body = json.loads(m.data[:MAX_PROBLEMS_TEXT])
            module, open_problems = str(body["module"]), body["open"]
            problems = [
                {"key": str(p.get("key", "")), "problem": str(p["problem"]), "fix": str(p.get("fix", ""))}
                for p in open_problems[:MAX_PROBLEMS]
            ]
        except (ValueError, KeyError, TypeError, AttributeError):
            return
        self.emit("problems", module=module, open=problems)

    def _on_state(self, m: SystemState, info: MessageInfo) -> None:
        if not self._foreign_states.accepts(info.sender):
            return
        self.emit("state", event=m.event, **{"from": m.from_system_state}, to=m.to_system_state)

    def _on_emotion(self, m: EmotionalState, info: MessageInfo) -> None:
        self.emit(
            "emotion",
            emotion=m.to_emotional_state,
            pleasure=round(m.current_pleasure, 4),
            arousal=round(m.current_arousal, 4),
            dominance=round(m.current_dominance, 4),
        )

    def _on_spoken(self, m: String, info: MessageInfo) -> None:
        self.emit("say", text=m.data)

    def _on_heard(self, m: String, info: MessageInfo) -> None:
        if self._long_heard.accepts(m.data, info.sender):
            self.emit("heard", text=m.data)

    def _on_recognised(self, m: String, info: MessageInfo) -> None:
        try:
            heard = json.loads(m.data)
            self.emit(
                "recognised",
                text=str(heard["text"]),
                confidence=float(heard["confidence"]),
                accepted=bool(heard["accepted"]),
            )
        except (ValueError, KeyError, TypeError):
            return  # not a speech input's record

    def _on_pose(self, m: PoseWithCovarianceStamped, info: MessageInfo) -> None:
        p = m.pose.pose
        pose = (
            round(p.position.x, 3),
            round(p.position.y, 3),
            round(yaw_of(p.orientation.z, p.orientation.w), 3),
        )
        if pose == self._last_pose:
            return
        since_last = None if self._last_pose_ns is None else self.now_ns() - self._last_pose_ns
        if since_last is not None and since_last < POSE_INTERVAL_NS:
            # Held back, not lost: the last pose of a trip (the arrival) comes out a moment later.
            self._pending_pose = pose
            if self._pose_flush is None:
                wait = (POSE_INTERVAL_NS - since_last) / NS_PER_S
                self._pose_flush = self.node.clock.call_later(wait, self._flush_pose)
            return
        self._emit_pose(pose)

    def _flush_pose(self) -> None:
        self._pose_flush = None
        pose, self._pending_pose = self._pending_pose, None
        if pose is not None and pose != self._last_pose:
            self._emit_pose(pose)

    def _emit_pose(self, pose: tuple[float, float, float]) -> None:
        self._last_pose, self._last_pose_ns = pose, self.now_ns()
        self.emit("pose", x=pose[0], y=pose[1], theta=pose[2])

    def _on_decision(self, m: String, info: MessageInfo) -> None:
        try:
            decision = json.loads(m.data)
        except json.JSONDecodeError:
            decision = {"event": None, "raw": m.data}
        self.emit(
            "motivator",
            event=decision.get("event"),
            candidates=decision.get("candidates", []),
            reason=decision.get("reason", ""),
            status=decision.get("status"),
            state=decision.get("state"),
        )
