"""The motivator's reward-cost rule: pure functions of the controller core.

The three PAD values are drives. Drive i has satiation sigma_i = (E_i + 1) / 2
and priority p_i = 1 - sigma_i^3. A motivational event promises a PAD reward;
on the drive scale that is a change d_i = reward_i / 2, so the event's reward is
R = sum_i p_i * d_i. Each event also carries a social saturation sigma_e in
[0, 1] that rises when it is chosen and falls otherwise; its cost is
c_e = cbrt(sigma_e) * sum_i d_i. Only events with R > c_e and R > 0 are
eligible (a negative reward has a negative cost, which must not make it pay).

No I/O, no clocks: the caller passes the current PAD point, the saturations and
elapsed seconds, and publishes whatever :func:`choose` decides.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from cyborg.emotion.model import PAD
from cyborg.errors import InvalidValueError


class SelectionRule(enum.StrEnum):
    """Which eligible event (reward > cost, reward > 0) wins; ties go to the first name.

    docs/motivator.md says why ``net`` is the default.
    """

    NET = "net"
    """Largest reward - cost (the default): the social cost counts in the ranking, so with the
    thesis's saturation step (+0.33 chosen, -0.05 others) a just-used event gives way to a fresh
    one, and the thesis's scenarios come out in its order (wander, music, wander, ...)."""
    REWARD = "reward"
    """Largest reward (thesis 2.6 read literally): an event is chosen again while it stays
    eligible, so its ``event_cost`` must push its cost above its reward for it to make way."""


class DecisionStatus(enum.StrEnum):
    """What came of one decision; every status but ``chosen`` means nothing was sent."""

    CHOSEN = "chosen"
    NO_EVENTS = "no_events"
    NOT_WORTH_IT = "not_worth_it"
    NOT_READY = "not_ready"
    HANDOVER = "handover"


class MotivationalEvent(BaseModel):
    """An event the motivator may send in ``state``, and the PAD reward it promises.

    ``event_cost`` is the amount added to this event's social saturation each
    time the motivator chooses it (the spec's add_event argument of the same
    name; 0.33 in the reference system, so about three uses in a row saturate
    it). ``None`` means "use ``MotivatorSettings.saturation_increment``". With the
    default selection rule an event is chosen again while it stays eligible; to
    give way after one use its saturation must pass (R / sum d)^3, about 0.67 at a
    neutral mood, so an event that must not repeat needs an ``event_cost`` near 1.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    state: str = Field(min_length=1)
    event: str = Field(min_length=1)
    reward_pleasure: float = Field(0.0, ge=-1.0, le=1.0)
    reward_arousal: float = Field(0.0, ge=-1.0, le=1.0)
    reward_dominance: float = Field(0.0, ge=-1.0, le=1.0)
    event_cost: float | None = Field(None, ge=0.0, le=1.0)

    @field_validator("state", "event")
    @classmethod
    def _no_blanks(cls, value: str) -> str:
        if value != value.strip() or any(c.isspace() for c in value):
            raise InvalidValueError(f"{value!r} contains whitespace: use a name like navigation_emotional")
        return value

    @property
    def reward(self) -> PAD:
        return PAD(self.reward_pleasure, self.reward_arousal, self.reward_dominance)


class MotivatorSettings(BaseModel):
    """The ``motivator:`` section of the controller's YAML configuration."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    rate_seconds: float = Field(2.0, gt=0.0, description="seconds between two decisions")
    saturation_increment: float = Field(
        0.33, ge=0.0, le=1.0, description="added to a chosen event's saturation (default event_cost)"
    )
    saturation_relief: float = Field(
        0.05, ge=0.0, le=1.0, description="taken from every other event's saturation on a choice"
    )
    saturation_decline_per_second: float = Field(
        0.001, ge=0.0, description="time-based decline of every saturation"
    )
    min_seconds_in_state: float = Field(
        10.0,
        ge=0.0,
        description="no choice until the controller has been this long in its current state",
    )
    idle_reset_seconds: float | None = Field(
        None, gt=0.0, description="after this long in one state all saturations reset to 0"
    )
    selection: SelectionRule = Field(
        SelectionRule.NET,
        description="net: the largest reward - cost wins (default); reward: the largest reward wins",
    )
    events: list[MotivationalEvent] = Field(default_factory=list)

    @model_validator(mode="after")
    def _unique_events(self) -> MotivatorSettings:
        seen: set[tuple[str, str]] = set()
        for e in self.events:
            if (e.state, e.event) in seen:
                raise InvalidValueError(
                    f"event {e.event!r} is listed twice for state {e.state!r}: keep one entry"
                )
            seen.add((e.state, e.event))
        return self

    def increment_for(self, event: MotivationalEvent) -> float:
        return self.saturation_increment if event.event_cost is None else event.event_cost


@dataclass(frozen=True)
class Candidate:
    """One event as the motivator weighed it."""

    event: MotivationalEvent
    reward: float
    cost: float
    net: float
    eligible: bool
    reason: str


@dataclass(frozen=True)
class Decision:
    """What :func:`choose` decided, with every candidate's numbers for the dashboard."""

    status: DecisionStatus
    chosen: MotivationalEvent | None
    candidates: tuple[Candidate, ...]
    reason: str


def satiation(e: float) -> float:
    """Normalise a PAD value in [-1, 1] to a drive satiation in [0, 1] (eq. 6.4)."""
    return (e + 1.0) / 2.0


def drive_priority(sigma: float) -> float:
    """p(sigma) = 1 - sigma^3: a starved drive matters most."""
    return 1.0 - sigma**3


def cost_priority(sigma_e: float) -> float:
    """p(sigma_e) = cbrt(sigma_e): the social cost rises steeply after the first use."""
    return math.copysign(abs(sigma_e) ** (1.0 / 3.0), sigma_e)


def drive_changes(event: MotivationalEvent) -> tuple[float, float, float]:
    """The change in each drive's satiation the event's PAD reward causes (reward / 2)."""
    return (event.reward_pleasure / 2.0, event.reward_arousal / 2.0, event.reward_dominance / 2.0)


def event_reward(pad: PAD, event: MotivationalEvent) -> float:
    """R = sum_i p_i(sigma_i) * d_i."""
    return sum(
        drive_priority(satiation(e)) * d for e, d in zip(pad.as_tuple(), drive_changes(event), strict=True)
    )


def event_cost(saturation: float, event: MotivationalEvent) -> float:
    """c_e = cbrt(sigma_e) * sum_i d_i."""
    return cost_priority(saturation) * sum(drive_changes(event))


def weigh(pad: PAD, event: MotivationalEvent, saturation: float) -> Candidate:
    reward = event_reward(pad, event)
    cost = event_cost(saturation, event)
    eligible = reward > max(cost, 0.0)
    if reward <= 0.0:
        verdict = "reward <= 0: it would not make the Cyborg happier"
    else:
        verdict = "reward > cost" if eligible else "reward <= cost"
    return Candidate(
        event=event,
        reward=reward,
        cost=cost,
        net=reward - cost,
        eligible=eligible,
        reason=f"{event.event}: reward {reward:.4f}, cost {cost:.4f} (saturation "
        f"{saturation:.2f}): {verdict}",
    )


def choose(
    pad: PAD,
    events_for_state: Sequence[MotivationalEvent],
    saturations: Mapping[str, float],
    *,
    state: str | None = None,
    rule: SelectionRule = SelectionRule.NET,
) -> Decision:
    """Pick the eligible event (reward > cost, reward > 0) that ``rule`` ranks highest.

    Saturations are keyed by event name (a missing name counts as 0). When
    ``state`` is given, events of other states are ignored. Ties are broken by
    the alphabetically first event name, so a decision is reproducible.
    """
    events = [e for e in events_for_state if state is None or e.state == state]
    where = f"state {state!r}" if state is not None else "the current state"
    if not events:
        return Decision(DecisionStatus.NO_EVENTS, None, (), f"no motivational events in {where}")
    candidates = tuple(weigh(pad, e, saturations.get(e.event, 0.0)) for e in events)
    eligible = [c for c in candidates if c.eligible]
    if not eligible:
        details = "; ".join(c.reason for c in candidates)
        return Decision(
            DecisionStatus.NOT_WORTH_IT,
            None,
            candidates,
            f"no candidate's reward exceeds its cost and 0 in {where}: {details}",
        )

    def rank(c: Candidate) -> tuple[float, str]:
        score = c.net if rule is SelectionRule.NET else c.reward
        return (-score, c.event.event)

    best = min(eligible, key=rank)
    return Decision(DecisionStatus.CHOSEN, best.event, candidates, best.reason)


def not_ready(state: str, seconds_in_state: float, settings: MotivatorSettings) -> Decision:
    """The decision while the controller has not been ``min_seconds_in_state`` in ``state``."""
    return Decision(
        DecisionStatus.NOT_READY,
        None,
        (),
        f"{seconds_in_state:.1f} s of {settings.min_seconds_in_state:g} s in state {state!r}: "
        "waiting before choosing (min_seconds_in_state)",
    )


def waiting_for_handover(state: str, what: str) -> Decision:
    """The decision while a handover is in progress: an event now could reach the next state."""
    return Decision(
        DecisionStatus.HANDOVER,
        None,
        (),
        f"a handover from state {state!r} is in progress ({what}): waiting for the state change",
    )


def apply_choice(
    saturations: Mapping[str, float],
    chosen: MotivationalEvent,
    all_events: Iterable[MotivationalEvent],
    settings: MotivatorSettings,
) -> dict[str, float]:
    """The chosen event's saturation rises by its increment (capped at 1); every
    other known event's falls by the relief (floored at 0)."""
    names = set(saturations) | {e.event for e in all_events} | {chosen.event}
    result: dict[str, float] = {}
    for name in sorted(names):
        value = saturations.get(name, 0.0)
        if name == chosen.event:
            result[name] = min(1.0, value + settings.increment_for(chosen))
        else:
            result[name] = max(0.0, value - settings.saturation_relief)
    return result


def decline(saturations: Mapping[str, float], elapsed_seconds: float, rate: float) -> dict[str, float]:
    """Every saturation falls linearly by ``rate`` per second, floored at 0."""
    if not (math.isfinite(elapsed_seconds) and elapsed_seconds >= 0.0):
        raise InvalidValueError(
            f"elapsed_seconds = {elapsed_seconds}: pass the non-negative time since the last decline"
        )
    return {name: max(0.0, value - rate * elapsed_seconds) for name, value in saturations.items()}


def is_ready(seconds_in_state: float, settings: MotivatorSettings) -> bool:
    """True once the controller has been in its state for ``min_seconds_in_state``.

    The pause lets modules' own events and feedback come first (the idle module's
    first boredom feedback makes the Cyborg unconcerned before it wanders).
    """
    return seconds_in_state >= settings.min_seconds_in_state


def should_reset(seconds_in_state: float, settings: MotivatorSettings) -> bool:
    """True when the controller has stayed in one state for ``idle_reset_seconds``."""
    limit = settings.idle_reset_seconds
    return limit is not None and seconds_in_state >= limit
