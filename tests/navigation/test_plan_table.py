"""``plan()`` answers as it did before it became a table of rules per origin, for every input it reads.

``reference_plan`` below is the earlier implementation, kept as the specification: every
origin (and none) x every emotion the emotion system names (and labels it does not) x the
requested and scheduled places x the places on the map x where the robot is x the places
without a pose or off the map x random seeds gives the same :class:`Plan`, and draws the same
random choices (the generator's next number is the same afterwards).

A change of what the robot decides belongs in ``reference_plan`` too, on purpose.
"""

from __future__ import annotations

import itertools
import math
import random
from collections.abc import Collection, Sequence

from cyborg.emotion.model import NEUTRAL, TABLE_2_2
from cyborg.navigation.behaviour import (
    ANGRY,
    BOSSED_AROUND,
    HAPPY,
    OWN_CHOICE,
    SCHEDULED,
    Origin,
    Plan,
    PlanKind,
    plan,
)
from cyborg.navigation.content import DEFAULT_LOCATIONS
from cyborg.navigation.models import Location


def reference_plan(
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
    if origin in (Origin.COMMAND, Origin.GUIDE):
        if requested is None:
            return Plan(PlanKind.NOTHING, "a command without a known place")
        if requested.name in no_pose:
            return Plan(PlanKind.NO_POSE, f"{requested.name} has no pose", requested)
        if requested.name in off_map:
            return Plan(PlanKind.NOT_ON_MAP, f"{requested.name} is not on the loaded map", requested)
        return Plan(PlanKind.MOVE, f"asked to go to {requested.name}", requested, BOSSED_AROUND)
    others = [p for p in places if here is None or p.name != here.name]
    if origin is Origin.SCHEDULE:
        if emotion == ANGRY:
            quiet = [p for p in others if not p.crowded]
            if quiet:
                target = rng.choice(quiet)
                return Plan(
                    PlanKind.MOVE,
                    f"angry: ignores the schedule, wants to be alone at {target.name}",
                    target,
                    OWN_CHOICE,
                )
        if scheduled is None:
            return Plan(PlanKind.NOTHING, "the scheduled event is over")
        return Plan(PlanKind.MOVE, f"scheduled to be at {scheduled.name}", scheduled, SCHEDULED)
    if origin is Origin.MOTIVATOR:
        if emotion in HAPPY:
            crowded = [p for p in others if p.crowded]
            if crowded:
                target = rng.choice(crowded)
                return Plan(
                    PlanKind.MOVE, f"{emotion}: looks for people at {target.name}", target, OWN_CHOICE
                )
        if emotion == ANGRY:
            quiet = [p for p in others if not p.crowded]
            if quiet:
                target = rng.choice(quiet)
                return Plan(PlanKind.MOVE, f"angry: wants to be alone at {target.name}", target, OWN_CHOICE)
        if emotion == "inhibited" and others:
            target = max(others, key=lambda p: p.pleasantness)
            return Plan(
                PlanKind.MOVE, f"inhibited: goes somewhere pleasant, {target.name}", target, OWN_CHOICE
            )
        return Plan(PlanKind.WANDER, f"{emotion}: wanders around", None, OWN_CHOICE)
    return Plan(PlanKind.NOTHING, "no reason to move")


ORIGINS: list[Origin | None] = [*Origin, None]
EMOTIONS = [*sorted([NEUTRAL, *TABLE_2_2]), "", "Angry", "happy"]  # and labels the table does not name
MAP = list(DEFAULT_LOCATIONS)
CROWDED = [p for p in MAP if p.crowded]
QUIET = [p for p in MAP if not p.crowded]
TIED = [Location("a", pleasantness=0.5), Location("b", pleasantness=0.5, crowded=True)]
PLACE_SETS = {"map": MAP, "crowded": CROWDED, "quiet": QUIET, "one": MAP[:1], "tied": TIED, "none": []}
ELSEWHERE = Location("the moon")
NO_POSE = Location("library")
OFF_MAP = Location("glassgården")
REQUESTS = [None, MAP[0], MAP[-1], ELSEWHERE, NO_POSE, OFF_MAP]
SCHEDULES = [None, MAP[1], ELSEWHERE]
HERE = [None, CROWDED[0], QUIET[0], TIED[0], ELSEWHERE]
ABSENT = [((), ()), ((OFF_MAP.name,), (NO_POSE.name,)), ((NO_POSE.name, OFF_MAP.name), (NO_POSE.name,))]
SEEDS = range(2)


def test_the_cases_reach_every_kind_of_plan() -> None:
    kinds = {
        reference_plan(
            origin,
            emotion,
            requested=requested,
            scheduled=None,
            places=MAP,
            rng=random.Random(0),
            off_map=(OFF_MAP.name,),
            no_pose=(NO_POSE.name,),
        ).kind
        for origin, emotion, requested in itertools.product(ORIGINS, EMOTIONS, REQUESTS)
    }
    assert kinds == set(PlanKind)


def test_plan_answers_as_the_reference_for_every_input() -> None:
    axes = (ORIGINS, EMOTIONS, REQUESTS, SCHEDULES, list(PLACE_SETS.items()), HERE, ABSENT, SEEDS)
    compared = 0
    for case in itertools.product(*axes):
        origin, emotion, requested, scheduled, (_, places), here, (off_map, no_pose), seed = case
        answers = []
        for decide in (reference_plan, plan):
            rng = random.Random(seed)
            chosen = decide(
                origin,
                emotion,
                requested=requested,
                scheduled=scheduled,
                places=places,
                rng=rng,
                here=here,
                off_map=off_map,
                no_pose=no_pose,
            )
            answers.append((chosen, rng.random()))  # the next draw tells whether both drew alike
        assert answers[1] == answers[0], case
        compared += 1
    assert compared == math.prod(len(axis) for axis in axes)
