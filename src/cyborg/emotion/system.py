"""The emotion system component (thesis 6.2, 8.2): PAD state on the transport.

Modules send ΔPAD on ``/cyborg_controller/emotional_feedback``; every update is
published on ``/cyborg_controller/emotional_state`` and the service
``/cyborg_controller/get_emotional_state`` answers the current emotion. The
command tool can set the emotion by name or by values and switch the system
on or off (while off, feedback is ignored).

Every fresh start is neutral with the system on (thesis 8.2). The state is kept
in the :class:`EmotionMemory` so that a controller brought back after a crash
while the rest of the robot runs on (``resume=True``) can resume it, if it was
stored within ``resume_within_seconds``. While the store cannot write (a full
disk) the emotion goes on in memory; the store says so and writes it once it can.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Protocol

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
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.clock import Periodic
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


@dataclass(frozen=True)
class StoredEmotion:
    """The persisted PAD point, the wall time of its last update and the on/off switch."""

    pad: PAD
    updated_at: float | None
    enabled: bool


class EmotionMemory(Protocol):
    """Where the emotion system keeps its point and switch across restarts (the controller's store)."""

    def get_emotion(self) -> StoredEmotion: ...

    def save_emotion(self, pad: PAD, updated_at: float) -> bool: ...

    def set_emotion_enabled(self, enabled: bool) -> bool: ...


class EmotionSystem:
    """Holds the PAD point and the named emotion; publishes every change."""

    def __init__(
        self,
        node: Node,
        settings: EmotionSettings,
        store: EmotionMemory | None = None,
        *,
        resume: bool = False,
    ) -> None:
        self.node = node
        self.settings = settings
        self.store = store
        self.stats = EmotionStats()
        self._prototypes = settings.emotion_prototypes
        self.pad = PAD(0.0, 0.0, 0.0)
        self.enabled = True
        self.resumed = False
        """True when this start took over the stored emotion (a restart after a crash)."""
        self._last_decay = node.clock.now()
        self._instant: list[tuple[str, PAD]] = []  # feedback of this instant, applied once it settles
        if store is not None:
            self._start_from(store, resume)
        self.emotion = self._name(None)
        if self.resumed:
            log.warning(
                "resumed the stored emotion %s (P %+.2f A %+.2f D %+.2f), emotion system %s",
                self.emotion,
                *self.pad.as_tuple(),
                "on" if self.enabled else "OFF",
            )
        self._share_switch()
        self._publisher = node.publisher(topics.EMOTIONAL_STATE, EmotionalState, latch=True)
        node.subscribe(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback, self._on_feedback, queue_size=1000)
        node.subscribe(topics.SET_EMOTIONAL_STATE, String, self._on_set_name)
        node.subscribe(topics.SET_EMOTIONAL_VALUES, EmotionalFeedback, self._on_set_values)
        node.subscribe(topics.EMOTIONAL_CONTROLLER, String, self._on_switch)
        node.advertise_service(topics.GET_EMOTIONAL_STATE, EmotionalStateService, self._on_get)
        self._decay: Periodic | None = None
        if settings.time_decay_half_lives is not None:
            self._decay = node.clock.every(
                TIME_DECAY_TICK, self._tick, name="the emotion's time decay", logger=log
            )
        self._publish(self.emotion)

    def close(self) -> None:
        """Stop the time decay (the store is closed by whoever opened it)."""
        if self._decay is not None:
            self._decay.cancel()

    def _start_from(self, store: EmotionMemory, resume: bool) -> None:
        """Take over the stored emotion on a resume within the window; otherwise store a neutral start."""
        stored = store.get_emotion()
        now = self.node.clock.now()
        age = None if stored.updated_at is None else now - stored.updated_at
        window = self.settings.resume_within_seconds
        if resume and age is not None and 0.0 <= age <= window:
            self.pad, self.enabled, self.resumed = stored.pad, stored.enabled, True
            if self.settings.time_decay_half_lives is not None:
                self.pad = time_decay(self.pad, age, self.settings.time_decay_half_lives)
            return
        if not resume:
            why = "a fresh start"
        elif window == 0.0:
            why = "resuming is off (resume_within_seconds: 0)"
        elif age is None:
            why = "no emotion was stored"
        else:
            why = f"the stored emotion is {age:.0f} s old, more than resume_within_seconds ({window:g} s)"
        log.info("the emotion system starts neutral and on: %s", why)
        store.save_emotion(self.pad, now)
        store.set_emotion_enabled(True)

    def _share_switch(self) -> None:
        """Keep the on/off switch in a parameter, where status tools over ROS read it."""
        try:
            self.node.set_param(topics.EMOTION_ENABLED_PARAM, self.enabled)
        except Exception as exc:  # a ROS master that does not answer must not stop the switch
            log.warning("could not set %s: %s", topics.EMOTION_ENABLED_PARAM, exc)

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
        if not self._instant:
            self.node.clock.when_settled(self._take_instant)
        self._instant.append((info.sender.lstrip("/"), delta))

    def _take_instant(self) -> None:
        """Apply the feedback of one instant, in order of sender and value: in one process and
        over ROS the messages of an instant come in different orders, and the update is not
        commutative (its cubic decay term). A set or a switch first applies what came before it."""
        if not self._instant:
            return
        instant, self._instant = sorted(self._instant, key=lambda item: (item[0], item[1].as_tuple())), []
        if not self.enabled:
            self.stats.ignored_while_off += len(instant)
            return
        self._apply_time_decay()
        for _, delta in instant:
            self.pad = update(self.pad, delta, self.settings.decay_rate)
        self._changed()

    def set_named(self, name: str) -> None:
        """Jump to the prototype ``name`` or an alias of it (the origin for neutral).

        Raises :class:`UnknownEmotion` (a ValueError) naming the known names if there is none.
        """
        name = self.settings.resolve(name)
        self._take_instant()
        self.pad = PAD(0.0, 0.0, 0.0) if name == NEUTRAL else PAD.of(self.settings.prototypes[name])
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
        self._take_instant()
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
        self._take_instant()
        self.enabled = word == "on"
        self._last_decay = self.node.clock.now()
        if self.store is not None:
            self.store.set_emotion_enabled(self.enabled)
        self._share_switch()
        log.info("emotion system switched %s by %s", word, info.sender)

    def _on_get(
        self, request: EmotionalStateServiceRequest, info: MessageInfo
    ) -> EmotionalStateServiceResponse:
        p, a, d = self.pad.as_tuple()
        return EmotionalStateServiceResponse(self.emotion, p, a, d)
