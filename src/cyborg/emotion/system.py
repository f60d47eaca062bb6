"""The emotion system component (thesis 6.2, 8.2): PAD state on the transport.

Modules send ΔPAD on ``/cyborg_controller/emotional_feedback``; every update is
published on ``/cyborg_controller/emotional_state`` and the service
``/cyborg_controller/get_emotional_state`` answers the current emotion. The
command tool can set the emotion by name or by values and switch the system
on or off (while off, feedback is ignored). The state survives restarts in the
:class:`ControllerStore`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

from cyborg.emotion.model import (
    NEUTRAL,
    PAD,
    EmotionSettings,
    InvalidFeedback,
    clamp,
    nearest_emotion,
    time_decay,
    update,
    validate_feedback,
)
from cyborg.emotion.store import ControllerStore
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.messages import (
    EmotionalFeedback,
    EmotionalState,
    EmotionalStateService,
    EmotionalStateServiceRequest,
    EmotionalStateServiceResponse,
    String,
)

log = logging.getLogger(__name__)

TIME_DECAY_TICK = 1.0


@dataclass
class EmotionStats:
    updates: int = 0
    rejected: int = 0
    ignored_while_off: int = 0


class EmotionSystem:
    """Holds the PAD point and the named emotion; publishes every change."""

    def __init__(self, node: Node, settings: EmotionSettings, store: ControllerStore | None = None) -> None:
        self.node = node
        self.settings = settings
        self.store = store
        self.stats = EmotionStats()
        self._prototypes = settings.emotion_prototypes
        self.pad = PAD(0.0, 0.0, 0.0)
        self.enabled = True
        self._last_decay = node.clock.now()
        if store is not None:
            stored = store.get_emotion()
            self.pad, self.enabled = stored.pad, stored.enabled
            if stored.updated_at is not None and settings.time_decay_half_lives is not None:
                offline = max(0.0, node.clock.now() - stored.updated_at)
                self.pad = time_decay(self.pad, offline, settings.time_decay_half_lives)
                log.info("decayed the emotion for %.0f s the robot was off", offline)
        self.emotion = self._name(None)
        self._publisher = node.publisher(topics.EMOTIONAL_STATE, EmotionalState, latch=True)
        node.subscribe(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback, self._on_feedback, queue_size=1000)
        node.subscribe(topics.SET_EMOTIONAL_STATE, String, self._on_set_name)
        node.subscribe(topics.SET_EMOTIONAL_VALUES, EmotionalFeedback, self._on_set_values)
        node.subscribe(topics.EMOTIONAL_CONTROLLER, String, self._on_switch)
        node.advertise_service(topics.GET_EMOTIONAL_STATE, EmotionalStateService, self._on_get)
        if settings.time_decay_half_lives is not None:
            node.clock.call_later(TIME_DECAY_TICK, self._tick)
        self._publish(self.emotion)

    def _name(self, current: str | None) -> str:
        return nearest_emotion(
            self.pad, self._prototypes, self.settings.threshold, current, self.settings.hysteresis
        )

    def _apply_time_decay(self) -> None:
        now = self.node.clock.now()
        elapsed, self._last_decay = max(0.0, now - self._last_decay), now
        if self.settings.time_decay_half_lives is not None and self.enabled:
            self.pad = time_decay(self.pad, elapsed, self.settings.time_decay_half_lives)

    def _tick(self) -> None:
        before = self.pad
        self._apply_time_decay()
        if before.distance(self.pad) >= 0.005 or self._name(self.emotion) != self.emotion:
            self._changed()
        self.node.clock.call_later(TIME_DECAY_TICK, self._tick)

    def _changed(self) -> None:
        previous = self.emotion
        self.emotion = self._name(previous)
        self.stats.updates += 1
        if self.store is not None:
            self.store.save_emotion(self.pad, self.node.clock.now())
        self._publish(previous)

    def _publish(self, previous: str) -> None:
        p, a, d = self.pad.as_tuple()
        self._publisher.publish(EmotionalState(previous, self.emotion, p, a, d))

    # --- inputs -----------------------------------------------------------------------

    def _on_feedback(self, message: EmotionalFeedback, info: MessageInfo) -> None:
        if not self.enabled:
            self.stats.ignored_while_off += 1
            return
        delta = PAD(message.delta_pleasure, message.delta_arousal, message.delta_dominance)
        try:
            validate_feedback(delta, self.settings.max_feedback_magnitude)
        except InvalidFeedback as exc:
            self.stats.rejected += 1
            log.warning("rejected feedback from %s: %s", info.sender, exc)
            return
        self._apply_time_decay()
        self.pad = update(self.pad, delta, self.settings.decay_rate)
        self._changed()

    def set_named(self, name: str) -> None:
        """Jump to the prototype ``name`` (or the origin for neutral); ValueError if unknown."""
        name = name.strip().lower()
        if name == NEUTRAL:
            self.pad = PAD(0.0, 0.0, 0.0)
        elif name in self.settings.prototypes:
            self.pad = PAD.of(self.settings.prototypes[name])
        else:
            known = ", ".join([NEUTRAL, *sorted(self.settings.prototypes)])
            raise ValueError(f"unknown emotion {name!r}; use one of {known}")
        self._last_decay = self.node.clock.now()
        self._changed()

    def _on_set_name(self, message: String, info: MessageInfo) -> None:
        try:
            self.set_named(message.data)
        except ValueError as exc:
            self.stats.rejected += 1
            log.warning("%s (sent by %s)", exc, info.sender)

    def _on_set_values(self, message: EmotionalFeedback, info: MessageInfo) -> None:
        values = (message.delta_pleasure, message.delta_arousal, message.delta_dominance)
        if not all(math.isfinite(v) and -1.0 <= v <= 1.0 for v in values):
            self.stats.rejected += 1
            log.warning("rejected PAD values %s from %s: each must be in [-1, 1]", values, info.sender)
            return
        self.pad = PAD.of(clamp(v) for v in values)
        self._last_decay = self.node.clock.now()
        self._changed()

    def _on_switch(self, message: String, info: MessageInfo) -> None:
        word = message.data.strip().lower()
        if word not in ("on", "off"):
            self.stats.rejected += 1
            log.warning(
                "emotional_controller expects 'on' or 'off', got %r from %s", message.data, info.sender
            )
            return
        self.enabled = word == "on"
        self._last_decay = self.node.clock.now()
        if self.store is not None:
            self.store.set_emotion_enabled(self.enabled)
        log.info("emotion system switched %s by %s", word, info.sender)

    def _on_get(
        self, request: EmotionalStateServiceRequest, info: MessageInfo
    ) -> EmotionalStateServiceResponse:
        p, a, d = self.pad.as_tuple()
        return EmotionalStateServiceResponse(self.emotion, p, a, d)
