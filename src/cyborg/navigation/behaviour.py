"""Pure decisions of the navigation module: where to go and what to say (thesis 7.5-7.7).

No I/O: the module passes in the emotion, the event that led to the state, the
known places and a random generator, and carries out what comes back.
"""

from __future__ import annotations

import enum
import random
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass

from cyborg.navigation.models import Location, Response, ResponseType

HAPPY = frozenset({"elated", "loved", "dignified"})
WANDERING_MOODS = frozenset({"bored", "curious", "unconcerned"})
ANGRY = "angry"
NEUTRAL = "neutral"


class Origin(enum.Enum):
    """Why the robot is going somewhere."""

    COMMAND = "command"  # "go to X"
    GUIDE = "guide"  # "where is X?" ... "yes"
    SCHEDULE = "schedule"  # a calendar event
    MOTIVATOR = "motivator"  # navigation_emotional


class PlanKind(enum.Enum):
    MOVE = "move"
    WANDER = "wander"
    NOT_ON_MAP = "not_on_map"  # asked for a known place that the loaded map does not have
    NO_POSE = "no_pose"  # asked for a known place whose pose nobody has given yet
    NOTHING = "nothing"


@dataclass(frozen=True)
class Plan:
    kind: PlanKind
    reason: str
    target: Location | None = None
    feedback: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Trip:
    """A drive under way: where to, and why (which decides what the robot says on arrival)."""

    origin: Origin | None
    target: Location


BOSSED_AROUND = (0.0, 0.0, -0.2)
SCHEDULED = (0.0, 0.0, -0.1)
OWN_CHOICE = (0.0, 0.0, 0.1)


def origin_of(event: str, guiding: bool) -> Origin | None:
    if event == "navigation_command":
        return Origin.GUIDE if guiding else Origin.COMMAND
    if event == "navigation_scheduler":
        return Origin.SCHEDULE
    if event == "navigation_emotional":
        return Origin.MOTIVATOR
    return None


def plan(
    origin: Origin | None,
    emotion: str,
    *,
    requested: Location | None,
    scheduled: Location | None,
    places: Sequence[Location],
    rng: random.Random,
    here: Location | None = None,
    off_map: Collection[str] = (),
    no_pose: Collection[str] = (),
) -> Plan:
    """Choose the target (or wandering) from why we plan and how the robot feels.

    ``places`` are the places with a pose on the loaded map (the only possible
    targets); ``off_map`` names known places that are not on it and ``no_pose``
    those with no pose at all: asked for one, the robot says so instead of driving
    to a pose that belongs to another map or to none. Each origin has its rule: a person's
    request, the calendar, the motivator's choice by emotion; without one there is nothing to do.
    """
    if origin is None:
        return Plan(PlanKind.NOTHING, "no reason to move")
    others = [p for p in places if here is None or p.name != here.name]
    situation = _Situation(requested, scheduled, others, rng, off_map, no_pose)
    return _RULES[origin](origin, emotion, situation)


@dataclass(frozen=True)
class _Situation:
    """What a rule of :func:`plan` chooses from besides the origin and the emotion."""

    requested: Location | None
    scheduled: Location | None
    others: Sequence[Location]
    """The possible targets, less the place the robot is at."""
    rng: random.Random
    off_map: Collection[str]
    no_pose: Collection[str]


def _asked(origin: Origin, emotion: str, situation: _Situation) -> Plan:
    """A person asked and said yes: go there, unless the place cannot be reached.

    An angry robot ignores a command before it gets here (the talking state, 7.7); once it
    asked and heard yes, it goes.
    """
    requested = situation.requested
    if requested is None:
        return Plan(PlanKind.NOTHING, "a command without a known place")
    if requested.name in situation.no_pose:
        return Plan(PlanKind.NO_POSE, f"{requested.name} has no pose", requested)
    if requested.name in situation.off_map:
        return Plan(PlanKind.NOT_ON_MAP, f"{requested.name} is not on the loaded map", requested)
    return Plan(PlanKind.MOVE, f"asked to go to {requested.name}", requested, BOSSED_AROUND)


def _scheduled(origin: Origin, emotion: str, situation: _Situation) -> Plan:
    """The calendar says where to be: go there, unless angry and some quiet place is free to be alone at."""
    if emotion == ANGRY:
        alone = _somewhere_quiet(situation, "angry: ignores the schedule, wants to be alone at")
        if alone is not None:
            return alone
    if situation.scheduled is None:
        return Plan(PlanKind.NOTHING, "the scheduled event is over")
    target = situation.scheduled
    return Plan(PlanKind.MOVE, f"scheduled to be at {target.name}", target, SCHEDULED)


def _own_choice(origin: Origin, emotion: str, situation: _Situation) -> Plan:
    """The motivator sends the robot off: where depends on the emotion (``_MOODS``), else it wanders."""
    choose = _MOODS.get(emotion)
    chosen = choose(emotion, situation) if choose is not None else None
    if chosen is not None:
        return chosen
    return Plan(PlanKind.WANDER, f"{emotion}: wanders around", None, OWN_CHOICE)


def _somewhere_crowded(emotion: str, situation: _Situation) -> Plan | None:
    """Happy: a random crowded place, to look for people (None if there is none)."""
    crowded = [p for p in situation.others if p.crowded]
    if not crowded:
        return None
    target = situation.rng.choice(crowded)
    return Plan(PlanKind.MOVE, f"{emotion}: looks for people at {target.name}", target, OWN_CHOICE)


def _somewhere_quiet(situation: _Situation, reason: str) -> Plan | None:
    """A random quiet place, the ``reason`` followed by its name (None if there is none)."""
    quiet = [p for p in situation.others if not p.crowded]
    if not quiet:
        return None
    target = situation.rng.choice(quiet)
    return Plan(PlanKind.MOVE, f"{reason} {target.name}", target, OWN_CHOICE)


def _be_alone(emotion: str, situation: _Situation) -> Plan | None:
    """Angry: a random quiet place, to be alone (None if there is none)."""
    return _somewhere_quiet(situation, "angry: wants to be alone at")


def _somewhere_pleasant(emotion: str, situation: _Situation) -> Plan | None:
    """Inhibited: the most pleasant place (the first of equals; None if there is none)."""
    if not situation.others:
        return None
    target = max(situation.others, key=lambda p: p.pleasantness)
    return Plan(PlanKind.MOVE, f"inhibited: goes somewhere pleasant, {target.name}", target, OWN_CHOICE)


_MOODS: dict[str, Callable[[str, _Situation], Plan | None]] = {
    **dict.fromkeys(HAPPY, _somewhere_crowded),
    ANGRY: _be_alone,
    "inhibited": _somewhere_pleasant,
}
"""Where the motivator's trip goes, by emotion; an emotion not here (or no such place) wanders."""

_RULES: dict[Origin, Callable[[Origin, str, _Situation], Plan]] = {
    Origin.COMMAND: _asked,
    Origin.GUIDE: _asked,
    Origin.SCHEDULE: _scheduled,
    Origin.MOTIVATOR: _own_choice,
}
"""How :func:`plan` chooses, by why the robot is going somewhere."""


def should_stop_wandering(emotion: str) -> bool:
    """Wandering ends once the robot is no longer bored, unconcerned or curious (thesis 11.3.1).

    It ends when the robot feels something else: elated, angry, puzzled, ... ``neutral`` does
    not end it: it is no emotion of its own but the region near no prototype (the threshold of
    docs/emotion-threshold.md), which the PAD values cross on their way from unconcerned to elated;
    the thesis's table, without that region, still called the robot unconcerned there and
    wandered on for about 120 s until it was elated (10.2.1). The module waits for the emotion
    to hold for a moment (``WANDER_DEBOUNCE``) so that one flicker of the label does not end it.
    """
    return emotion not in WANDERING_MOODS and emotion != NEUTRAL


class TalkKind(enum.Enum):
    ARRIVED = "arrived"
    STUCK = "stuck"
    OPINION = "opinion"
    NOTHING = "nothing"


def talk_kind(event: str, origin: Origin | None) -> TalkKind:
    """What the talking state says for the end of a trip (7.7): a person's request is for
    :func:`cyborg.navigation.dialogue.reply_to`.

    Arrived as a guide it names the place; arrived otherwise it gives its opinion; stuck, it says so.
    """
    if event == "succeeded":
        return TalkKind.ARRIVED if origin is Origin.GUIDE else TalkKind.OPINION
    if event == "aborted":
        return TalkKind.STUCK
    return TalkKind.NOTHING


def sentence(responses: Sequence[Response], location: str, rng: random.Random) -> str | None:
    if not responses:
        return None
    return rng.choice(list(responses)).say(location)


RESPONSE_FOR_TALK = {
    TalkKind.ARRIVED: ResponseType.ARRIVED,
    TalkKind.STUCK: ResponseType.STUCK,
    TalkKind.OPINION: ResponseType.OPINION,
}
