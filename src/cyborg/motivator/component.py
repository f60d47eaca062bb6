"""The motivator component (thesis 6.3, 8.3): picks events when nothing else happens.

Every ``rate_seconds`` it weighs the motivational events registered for the
active state (those that are transitions of it) and publishes the decision on
``/cyborg_controller/motivator_decision`` (JSON: status, reason and every
candidate's reward, cost and net), also when nothing is chosen. When an event
is worth it, it publishes the event on ``register_event``, like any module; once
the controller has taken it (a state change by that event from the state it was
chosen in) it sends the event's reward as emotional feedback and raises the
event's saturation. An event the controller did not take (another module's
event came first) gives neither. It does not decide while a handover is in
progress: from any event that is a transition of the active state (its own or
another module's, seen on ``register_event``) until the state changes, and
while the in-process controller, if given, is not simply running a module.
"""

from __future__ import annotations

import json
import logging
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

from cyborg.controller.machine import MachineSpec
from cyborg.emotion.model import PAD
from cyborg.motivator.logic import (
    Decision,
    DecisionStatus,
    MotivationalEvent,
    MotivatorSettings,
    apply_choice,
    choose,
    decline,
    is_ready,
    not_ready,
    should_reset,
    waiting_for_handover,
)
from cyborg.motivator.store import ControllerStore
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.clock import Periodic
from cyborg.transport.messages import EmotionalFeedback, EmotionalState, String, SystemState

log = logging.getLogger(__name__)

HANDOVER_MARGIN = 1.0
"""Seconds beyond the controller's preempt and connect timeouts before a handover counts as lost."""


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


@dataclass(frozen=True)
class _Handover:
    event: str
    sender: str
    since: float


@dataclass(frozen=True)
class _Sent:
    """A chosen event on its way to the controller: rewarded once a state change shows it taken."""

    event: MotivationalEvent
    state: str


class Motivator:
    """Chooses motivational events on a timer; counts what it chose.

    ``controller_busy`` (see :func:`cyborg.app.robot.controller_busy`) lets a motivator in the controller's
    process also wait for handovers it cannot see on the topics.
    """

    def __init__(
        self,
        node: Node,
        settings: MotivatorSettings,
        machine: MachineSpec,
        store: ControllerStore,
        *,
        controller_busy: Callable[[], bool] | None = None,
    ) -> None:
        self.node = node
        self.settings = settings
        self.machine = machine
        self.store = store
        self.controller_busy = controller_busy
        self.state: str | None = None
        self.entered_at = node.clock.monotonic()
        self.pad = PAD(0.0, 0.0, 0.0)
        self.saturations = store.get_saturations()
        self.chosen = Counter[str]()
        """Events the controller took, by name (each was rewarded)."""
        self.not_taken = Counter[str]()
        """Events sent but not taken (another event came first): no reward, no saturation."""
        self._sent: _Sent | None = None
        self.last_decision: Decision | None = None
        self.handover_patience = machine.timeouts.preempt + machine.timeouts.connect + HANDOVER_MARGIN
        self._handover: _Handover | None = None
        self._last_logged: tuple[DecisionStatus, str] | None = None
        self._last_tick = node.clock.monotonic()
        self._events = node.publisher(topics.REGISTER_EVENT, String)
        self._feedback = node.publisher(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback)
        self._decisions = node.publisher(topics.MOTIVATOR_DECISION, String)
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_state)
        node.subscribe(topics.EMOTIONAL_STATE, EmotionalState, self._on_emotion)
        node.subscribe(topics.REGISTER_EVENT, String, self._on_event, queue_size=100)
        self._ticks: Periodic = node.clock.every(
            settings.rate_seconds, self._decide, name="the motivator's decision", logger=log
        )

    def close(self) -> None:
        """Stop deciding (the store is closed by whoever opened it)."""
        self._ticks.cancel()

    def events_for(self, state: str) -> list[MotivationalEvent]:
        """Registered events of ``state`` that are transitions of it (others are ignored)."""
        valid = self.machine.transitions_of(state) if state in self.machine.states else {}
        return [e for e in self.store.list_events(state) if e.event in valid]

    def _on_state(self, message: SystemState, info: MessageInfo) -> None:
        sent, self._sent = self._sent, None
        if sent is not None:
            if message.event == sent.event.event and message.from_system_state == sent.state:
                self._reward(sent.event)
            else:
                self._not_taken(sent, f"the controller took {message.event!r} instead")
        self.state = message.to_system_state
        self.entered_at = self.node.clock.monotonic()
        self._handover = None

    def _on_emotion(self, message: EmotionalState, info: MessageInfo) -> None:
        self.pad = PAD(message.current_pleasure, message.current_arousal, message.current_dominance)

    def _on_event(self, message: String, info: MessageInfo) -> None:
        name = message.data.strip()
        state = self.state
        if state is None or state not in self.machine.states or self.machine.lookup(state, name) is None:
            return  # the controller drops it; no handover follows
        if self._handover is None:
            self._handover = _Handover(name, info.sender, self.node.clock.monotonic())

    def _handover_in_progress(self, now: float) -> str | None:
        """What the motivator waits for, or None when it may decide."""
        handover = self._handover
        if handover is not None:
            if now - handover.since < self.handover_patience:
                return f"event {handover.event!r} from {handover.sender}"
            log.warning(
                "no state change %.1f s after event %r from %s in %s; deciding again",
                now - handover.since,
                handover.event,
                handover.sender,
                self.state,
            )
            self._handover = None
            if self._sent is not None:
                self._not_taken(self._sent, "no state change followed")
                self._sent = None
        if self.controller_busy is not None and self.controller_busy():
            return "the controller is not running a module"
        return None

    def _decide(self) -> None:
        now = self.node.clock.monotonic()
        elapsed, self._last_tick = now - self._last_tick, now
        self.saturations = decline(self.saturations, elapsed, self.settings.saturation_decline_per_second)
        state = self.state
        if state is None:
            return  # the controller has not entered its first state yet
        in_state = now - self.entered_at
        if should_reset(in_state, self.settings) and any(self.saturations.values()):
            log.info("%.0f s in %s: resetting the motivator's saturations", in_state, state)
            self.saturations = dict.fromkeys(self.saturations, 0.0)
        waiting_for = self._handover_in_progress(now)
        if waiting_for is not None:
            decision = waiting_for_handover(state, waiting_for)
        elif not is_ready(in_state, self.settings):
            decision = not_ready(state, in_state, self.settings)
        else:
            decision = choose(
                self.pad, self.events_for(state), self.saturations, state=state, rule=self.settings.selection
            )
        self._publish(decision, state)
        if decision.chosen is not None:
            self._send(decision.chosen, state, now)

    def _publish(self, decision: Decision, state: str) -> None:
        """Publish every decision; log choices and changed reasons at INFO, repeated ones at DEBUG."""
        self.last_decision = decision
        self._decisions.publish(String(data=decision_json(decision, state)))
        if decision.chosen is not None:
            log.info("motivator chose %s in %s: %s", decision.chosen.event, state, decision.reason)
            self._last_logged = None
            return
        key = (decision.status, state)
        level = logging.DEBUG if key == self._last_logged else logging.INFO
        self._last_logged = key
        log.log(level, "motivator chose nothing in %s: %s", state, decision.reason)

    def _send(self, chosen: MotivationalEvent, state: str, now: float) -> None:
        self._handover = _Handover(chosen.event, self.node.name, now)
        self._sent = _Sent(chosen, state)
        self._events.publish(String(data=chosen.event))

    def _reward(self, chosen: MotivationalEvent) -> None:
        """The controller took ``chosen``: its PAD reward as feedback (thesis 8.3), then the saturations."""
        self.chosen[chosen.event] += 1
        self._feedback.publish(
            EmotionalFeedback(chosen.reward_pleasure, chosen.reward_arousal, chosen.reward_dominance)
        )
        self.saturations = apply_choice(self.saturations, chosen, self.store.list_events(), self.settings)
        self.store.save_saturations(self.saturations)

    def _not_taken(self, sent: _Sent, why: str) -> None:
        self.not_taken[sent.event.event] += 1
        log.info(
            "motivator's %s in %s was not taken (%s): no reward, saturation unchanged",
            sent.event.event,
            sent.state,
            why,
        )
