"""The navigation module's pure decisions (thesis 7.5 and 7.7): where to go and what to say.

``plan()`` is checked for every origin (why the robot plans) and every emotion
the emotion system can name; ``talk_kind()`` for the end of a trip and ``reply_to()``
(what the talking state answers a person's request, thesis 7.7) for every request and emotion.
"""

from __future__ import annotations

import random

import pytest

from cyborg.emotion.model import NEUTRAL, TABLE_2_2
from cyborg.navigation.behaviour import (
    BOSSED_AROUND,
    HAPPY,
    Origin,
    Plan,
    PlanKind,
    TalkKind,
    origin_of,
    plan,
    should_stop_wandering,
    talk_kind,
)
from cyborg.navigation.content import DEFAULT_LOCATIONS
from cyborg.navigation.dialogue import Answer, ReplyKind, Request, after_answer, reply_to
from cyborg.navigation.keywords import Intent
from cyborg.navigation.models import Location, ResponseType

EMOTIONS = sorted([NEUTRAL, *TABLE_2_2])
PLACES = {place.name: place for place in DEFAULT_LOCATIONS}
CROWDED = {name for name, place in PLACES.items() if place.crowded}
QUIET = set(PLACES) - CROWDED
CAFETERIA, EL6 = PLACES["cafeteria"], PLACES["el6"]
SEEDS = range(20)


def plan_for(
    origin: Origin | None,
    emotion: str,
    *,
    requested: Location | None = None,
    scheduled: Location | None = None,
    here: Location | None = None,
    seed: int = 0,
) -> Plan:
    return plan(
        origin,
        emotion,
        requested=requested,
        scheduled=scheduled,
        places=list(PLACES.values()),
        rng=random.Random(seed),
        here=here,
    )


def test_the_default_places_cover_every_case() -> None:
    assert len(CROWDED) >= 2 and len(QUIET) >= 2
    assert max(PLACES.values(), key=lambda p: p.pleasantness) is CAFETERIA


# --- a user's command ("go to X") -------------------------------------------------------


@pytest.mark.parametrize("emotion", EMOTIONS)
def test_a_confirmed_command_goes_to_the_place(emotion: str) -> None:
    chosen = plan_for(Origin.COMMAND, emotion, requested=EL6, scheduled=CAFETERIA)
    assert chosen.target == EL6
    assert chosen.feedback == (0.0, 0.0, -0.2)  # bossed around: dominance down
    assert chosen.kind is PlanKind.MOVE  # confirmed: even an angry robot goes (it ignores commands earlier)


@pytest.mark.parametrize("emotion", EMOTIONS)
def test_guiding_goes_to_the_place_it_offered_to_show(emotion: str) -> None:
    chosen = plan_for(Origin.GUIDE, emotion, requested=EL6)
    assert (chosen.kind, chosen.target) == (PlanKind.MOVE, EL6)
    assert chosen.feedback == BOSSED_AROUND


@pytest.mark.parametrize("origin", [Origin.COMMAND, Origin.GUIDE])
def test_command_without_a_known_place_does_nothing(origin: Origin) -> None:
    chosen = plan_for(origin, NEUTRAL, requested=None, scheduled=CAFETERIA)
    assert chosen.kind is PlanKind.NOTHING
    assert chosen.target is None and chosen.feedback == (0.0, 0.0, 0.0)


# --- a calendar event ---------------------------------------------------------------------


@pytest.mark.parametrize("emotion", EMOTIONS)
def test_schedule_goes_to_the_place_but_angry_goes_somewhere_quiet(emotion: str) -> None:
    for seed in SEEDS:
        chosen = plan_for(Origin.SCHEDULE, emotion, scheduled=CAFETERIA, seed=seed)
        assert chosen.kind is PlanKind.MOVE
        assert chosen.target is not None
        if emotion == "angry":
            assert chosen.target.name in QUIET  # ignores the event to be alone
            assert chosen.feedback == (0.0, 0.0, 0.1)  # its own choice: dominance up
        else:
            assert chosen.target == CAFETERIA
            assert chosen.feedback == (0.0, 0.0, -0.1)  # told where to be: dominance down a little


def test_angry_schedule_never_picks_where_it_already_is() -> None:
    for seed in SEEDS:
        chosen = plan_for(Origin.SCHEDULE, "angry", scheduled=CAFETERIA, here=EL6, seed=seed)
        assert chosen.target is not None and chosen.target.name in QUIET - {"el6"}


@pytest.mark.parametrize("emotion", sorted(set(EMOTIONS) - {"angry"}))
def test_schedule_that_is_over_does_nothing(emotion: str) -> None:
    assert plan_for(Origin.SCHEDULE, emotion, scheduled=None).kind is PlanKind.NOTHING


# --- the motivator (navigation_emotional) ---------------------------------------------------


def expected_motivator_kind(emotion: str) -> str:
    if emotion in ("elated", "loved", "dignified"):
        return "crowded"
    if emotion == "angry":
        return "quiet"
    if emotion == "inhibited":
        return "pleasant"
    return "wander"


@pytest.mark.parametrize("emotion", EMOTIONS)
def test_motivator_chooses_by_emotion(emotion: str) -> None:
    expected = expected_motivator_kind(emotion)
    targets = set()
    for seed in SEEDS:
        chosen = plan_for(Origin.MOTIVATOR, emotion, scheduled=EL6, seed=seed)
        assert chosen.feedback == (0.0, 0.0, 0.1)  # its own idea: dominance up
        if expected == "wander":
            assert (chosen.kind, chosen.target) == (PlanKind.WANDER, None)
            continue
        assert chosen.kind is PlanKind.MOVE and chosen.target is not None
        targets.add(chosen.target.name)
    if expected == "crowded":
        assert targets <= CROWDED and len(targets) > 1  # a random crowded place, not always the same
    elif expected == "quiet":
        assert targets <= QUIET and len(targets) > 1
    elif expected == "pleasant":
        assert targets == {"cafeteria"}


def test_the_spec_names_wander_for_bored_curious_unconcerned_and_neutral() -> None:
    for emotion in ("bored", "curious", "unconcerned", NEUTRAL):
        assert plan_for(Origin.MOTIVATOR, emotion).kind is PlanKind.WANDER
    assert {"elated", "loved", "dignified"} == HAPPY


def test_motivator_goes_somewhere_else_than_here() -> None:
    for seed in SEEDS:
        happy = plan_for(Origin.MOTIVATOR, "elated", here=CAFETERIA, seed=seed)
        assert happy.target is not None and happy.target.name in CROWDED - {"cafeteria"}
    sad = plan_for(Origin.MOTIVATOR, "inhibited", here=CAFETERIA)
    assert sad.target == PLACES["waiting area"]  # the next most pleasant place


def test_happy_without_crowded_places_wanders() -> None:
    quiet = [place for place in PLACES.values() if not place.crowded]
    chosen = plan(
        Origin.MOTIVATOR, "elated", requested=None, scheduled=None, places=quiet, rng=random.Random(0)
    )
    assert chosen.kind is PlanKind.WANDER


def test_motivator_choice_is_deterministic_for_a_seed() -> None:
    runs = [[plan_for(Origin.MOTIVATOR, "elated", seed=seed).target for seed in SEEDS] for _ in range(2)]
    assert runs[0] == runs[1]


def test_no_reason_to_plan_does_nothing() -> None:
    assert plan_for(None, "elated", requested=EL6, scheduled=CAFETERIA).kind is PlanKind.NOTHING


@pytest.mark.parametrize(
    ("event", "guiding", "origin"),
    [
        ("navigation_command", False, Origin.COMMAND),
        ("navigation_command", True, Origin.GUIDE),
        ("navigation_scheduler", False, Origin.SCHEDULE),
        ("navigation_emotional", False, Origin.MOTIVATOR),
        ("succeeded", False, None),
        ("start", True, None),
    ],
)
def test_origin_of_event(event: str, guiding: bool, origin: Origin | None) -> None:
    assert origin_of(event, guiding) is origin


@pytest.mark.parametrize("emotion", EMOTIONS)
def test_wandering_stops_once_no_longer_bored_unconcerned_or_curious(emotion: str) -> None:
    # neutral is no emotion of its own: the robot passes through it on its way to another one
    assert should_stop_wandering(emotion) is (emotion not in ("bored", "unconcerned", "curious", "neutral"))


@pytest.mark.parametrize("origin", [Origin.COMMAND, Origin.GUIDE])
@pytest.mark.parametrize("emotion", EMOTIONS)
def test_a_requested_place_off_the_loaded_map_is_not_a_target(origin: Origin, emotion: str) -> None:
    chosen = plan(
        origin,
        emotion,
        requested=EL6,
        scheduled=None,
        places=[CAFETERIA],
        rng=random.Random(0),
        off_map={"el6"},
    )
    assert (chosen.kind, chosen.target) == (PlanKind.NOT_ON_MAP, EL6)
    assert chosen.feedback == (0.0, 0.0, 0.0)


def test_asked_where_a_place_off_the_map_is_it_does_not_offer_to_show_it() -> None:
    where = reply_to(Request(Intent.NAVIGATION_INFORMATION, EL6), NEUTRAL, on_map=False)
    assert (where.kind, where.say) == (ReplyKind.SAY, ResponseType.NOT_ON_MAP)
    opinion = reply_to(Request(Intent.NAVIGATION_FEEDBACK, EL6), NEUTRAL, on_map=False)
    assert (opinion.kind, opinion.say) == (ReplyKind.SAY, ResponseType.OPINION)


@pytest.mark.parametrize("origin", [Origin.COMMAND, Origin.GUIDE])
@pytest.mark.parametrize("emotion", EMOTIONS)
def test_a_requested_place_without_a_pose_is_not_a_target(origin: Origin, emotion: str) -> None:
    """Issue 11.6: a place nobody has placed yet; it is also on no map, but "no pose" is what it says."""
    chosen = plan(
        origin,
        emotion,
        requested=EL6,
        scheduled=None,
        places=[],
        rng=random.Random(0),
        off_map={"el6"},
        no_pose={"el6"},
    )
    assert (chosen.kind, chosen.target, chosen.feedback) == (PlanKind.NO_POSE, EL6, (0.0, 0.0, 0.0))


def test_asked_where_a_place_without_a_pose_is_it_says_it_does_not_know() -> None:
    for intent in (Intent.NAVIGATION_INFORMATION, Intent.NAVIGATION_COMMAND):
        reply = reply_to(Request(intent, EL6), NEUTRAL, on_map=False, has_pose=False)
        assert (reply.kind, reply.say) == (ReplyKind.SAY, ResponseType.NO_POSE)
    opinion = reply_to(Request(Intent.NAVIGATION_FEEDBACK, EL6), NEUTRAL, has_pose=False)
    assert opinion.say is ResponseType.OPINION  # it may think something of a place it cannot find


# --- what the talking state says ----------------------------------------------------------

ORIGINS: list[Origin | None] = [*Origin, None]


@pytest.mark.parametrize("origin", ORIGINS)
@pytest.mark.parametrize(
    ("event", "kind"),
    [
        ("succeeded", None),  # depends on the origin
        ("aborted", TalkKind.STUCK),
        ("navigation_feedback", TalkKind.NOTHING),  # a person's request: reply_to's
        ("start", TalkKind.NOTHING),
    ],
)
def test_talk_kind(event: str, kind: TalkKind | None, origin: Origin | None) -> None:
    if kind is None:  # arriving: names the place when guiding, else gives an opinion
        kind = TalkKind.ARRIVED if origin is Origin.GUIDE else TalkKind.OPINION
    assert talk_kind(event, origin) is kind


# --- a person's request in the talking state (7.7) --------------------------------------


@pytest.mark.parametrize("emotion", EMOTIONS)
def test_a_command_asks_for_confirmation_unless_angry(emotion: str) -> None:
    """7.7: "ignore the command if it is angry, otherwise ask for confirmation"."""
    reply = reply_to(Request(Intent.NAVIGATION_COMMAND, EL6), emotion)
    if emotion == "angry":
        assert (reply.kind, reply.say, reply.then) == (ReplyKind.IGNORE, None, None)
        return
    assert (reply.kind, reply.say) == (ReplyKind.ASK, ResponseType.ASK_GO)
    go = after_answer(reply, Answer.YES)
    assert go is not None and (go.kind, go.say, go.origin, go.place) == (
        ReplyKind.GO,
        ResponseType.CONFIRM,
        Origin.COMMAND,
        EL6,
    )
    declined = after_answer(reply, Answer.NO)
    assert declined is not None and (declined.kind, declined.say) == (ReplyKind.SAY, ResponseType.DECLINED)
    assert after_answer(reply, Answer.SILENCE) is None


@pytest.mark.parametrize("emotion", EMOTIONS)
def test_where_is_offers_to_guide_whatever_the_emotion(emotion: str) -> None:
    reply = reply_to(Request(Intent.NAVIGATION_INFORMATION, EL6), emotion)
    assert (reply.kind, reply.say) == (ReplyKind.ASK, ResponseType.OFFER_GUIDE)
    go = after_answer(reply, Answer.YES)
    assert go is not None and (go.kind, go.origin) == (ReplyKind.GO, Origin.GUIDE)


@pytest.mark.parametrize("intent", [Intent.NAVIGATION_COMMAND, Intent.NAVIGATION_INFORMATION])
def test_a_request_with_its_own_question_is_asked_first(intent: Intent) -> None:
    """The general yes-or-no: e.g. "Did you mean el6?"; yes goes on with the request's own rule."""
    question = ResponseType.OFFER_GUIDE  # any kind of sentence serves as the question
    reply = reply_to(Request(intent, EL6, question=question), NEUTRAL)
    assert (reply.kind, reply.say) == (ReplyKind.ASK, question)
    assert after_answer(reply, Answer.YES) == reply_to(Request(intent, EL6), NEUTRAL)
    declined = after_answer(reply, Answer.NO)
    assert declined is not None and declined.say is ResponseType.DECLINED
