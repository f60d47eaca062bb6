"""The motivator component (thesis 6.3, 8.3): picks events when nothing else happens.

Every ``rate_seconds`` it weighs the motivational events registered for the
active state (those that are transitions of it), publishes the decision with
every candidate on ``/cyborg_controller/motivator_decision`` (JSON), and, when
an event is worth it, publishes the event on ``register_event`` and its reward
as emotional feedback, like any module. It waits while a handover is in
progress (from sending an event until the state changes).
"""

from __future__ import annotations

import json
import logging
from collections import Counter

from cyborg.controller.machine import MachineSpec
from cyborg.emotion.model import PAD
from cyborg.emotion.store import ControllerStore
from cyborg.motivator.logic import (
    Decision,
    MotivationalEvent,
    MotivatorSettings,
    apply_choice,
    choose,
    decline,
    is_ready,
    should_reset,
)
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.messages import EmotionalFeedback, EmotionalState, String, SystemState

log = logging.getLogger(__name__)

HANDOVER_PATIENCE = 5.0


def decision_json(decision: Decision, state: str | None) -> str:
    return json.dumps(
        {
            "state": state,
            "status": decision.status.value,
            "event": decision.chosen.event if decision.chosen else None,
            "reason": decision.reason,
            "candidates": [
                {
                    "event": c.event.event,
                    "reward": round(c.reward, 5),
                    "cost": round(c.cost, 5),
                    "net": round(c.net, 5),
                    "eligible": c.eligible,
                }
                for c in decision.candidates
            ],
        }
    )


class Motivator:
    """Chooses motivational events on a timer; counts what it chose."""

    def __init__(
        self, node: Node, settings: MotivatorSettings, machine: MachineSpec, store: ControllerStore
    ) -> None:
        self.node = node
        self.settings = settings
        self.machine = machine
        self.store = store
        self.state: str | None = None
        self.entered_at = node.clock.monotonic()
        self.pad = PAD(0.0, 0.0, 0.0)
        self.saturations = store.get_saturations()
        self.chosen = Counter[str]()
        self.last_decision: Decision | None = None
        self._awaiting_handover_until: float | None = None
        self._last_tick = node.clock.monotonic()
        self._events = node.publisher(topics.REGISTER_EVENT, String)
        self._feedback = node.publisher(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback)
        self._decisions = node.publisher(topics.MOTIVATOR_DECISION, String)
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_state)
        node.subscribe(topics.EMOTIONAL_STATE, EmotionalState, self._on_emotion)
        node.clock.call_later(settings.rate_seconds, self._tick)

    def events_for(self, state: str) -> list[MotivationalEvent]:
        """Registered events of ``state`` that are transitions of it (others are ignored)."""
        valid = self.machine.transitions_of(state) if state in self.machine.states else {}
        return [e for e in self.store.list_events(state) if e.event in valid]

    def _on_state(self, message: SystemState, info: MessageInfo) -> None:
        self.state = message.to_system_state
        self.entered_at = self.node.clock.monotonic()
        self._awaiting_handover_until = None

    def _on_emotion(self, message: EmotionalState, info: MessageInfo) -> None:
        self.pad = PAD(message.current_pleasure, message.current_arousal, message.current_dominance)

    def _tick(self) -> None:
        try:
            self._decide()
        except Exception:
            log.exception("motivator decision failed; trying again next tick")
        finally:
            self.node.clock.call_later(self.settings.rate_seconds, self._tick)

    def _decide(self) -> None:
        now = self.node.clock.monotonic()
        elapsed, self._last_tick = now - self._last_tick, now
        self.saturations = decline(self.saturations, elapsed, self.settings.saturation_decline_per_second)
        if self.state is None:
            return
        if self._awaiting_handover_until is not None and now < self._awaiting_handover_until:
            return  # a handover we asked for is still in progress
        in_state = now - self.entered_at
        if should_reset(in_state, self.settings) and any(self.saturations.values()):
            log.info("%.0f s in %s: resetting the motivator's saturations", in_state, self.state)
            self.saturations = dict.fromkeys(self.saturations, 0.0)
        if not is_ready(in_state, self.settings):
            return
        decision = choose(
            self.pad,
            self.events_for(self.state),
            self.saturations,
            state=self.state,
            rule=self.settings.selection,
        )
        self.last_decision = decision
        if decision.candidates:
            self._decisions.publish(String(data=decision_json(decision, self.state)))
        if decision.chosen is None:
            log.debug("motivator in %s chose nothing: %s", self.state, decision.reason)
            return
        chosen = decision.chosen
        log.info("motivator chose %s in %s: %s", chosen.event, self.state, decision.reason)
        self.chosen[chosen.event] += 1
        self._events.publish(String(data=chosen.event))
        self._feedback.publish(
            EmotionalFeedback(chosen.reward_pleasure, chosen.reward_arousal, chosen.reward_dominance)
        )
        self.saturations = apply_choice(self.saturations, chosen, self.store.list_events(), self.settings)
        self.store.save_saturations(self.saturations)
        self._awaiting_handover_until = now + HANDOVER_PATIENCE
