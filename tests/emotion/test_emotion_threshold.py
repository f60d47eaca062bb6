"""The default threshold reproduces the emotions the spec's scenarios report.

Feedback magnitudes and the arithmetic are in docs/emotion-threshold.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from cyborg.emotion.model import NEUTRAL, PAD, EmotionSettings, nearest_emotion, update

ORIGIN = PAD()
IDLE = PAD(-0.05, -0.05, -0.05)
MOTIVATOR_NAVIGATION = PAD(0.0, 0.05, -0.01)
PLAN_OWN_CHOICE = PAD(0.0, 0.0, 0.1)
PLAN_CALENDAR = PAD(0.0, 0.0, -0.1)
COMMANDED = PAD(0.0, 0.0, -0.2)
WANDER = PAD(0.02, 0.05, 0.02)
MOVE = PAD(0.0, 0.015, 0.01)
PLEASANT_ARRIVAL = PAD(0.1, 0.0, 0.0)


def labels(
    steps: Sequence[PAD],
    settings: EmotionSettings | None = None,
    start: PAD = ORIGIN,
    current: str = NEUTRAL,
) -> tuple[list[str], PAD]:
    s = settings or EmotionSettings()
    pad, out = start, []
    for delta in steps:
        pad = update(pad, delta, s.decay_rate)
        current = nearest_emotion(pad, s.emotion_prototypes, s.threshold, current, s.hysteresis)
        out.append(current)
    return out, pad


def test_startup_point_is_neutral() -> None:
    s = EmotionSettings()
    assert nearest_emotion(PAD(), s.emotion_prototypes, s.threshold) == NEUTRAL


def test_first_idle_feedback_makes_the_cyborg_unconcerned() -> None:
    # distance 0.391 <= 0.40
    assert labels([IDLE])[0] == ["unconcerned"]


def test_scenario_a1_unconcerned_planner_then_elated_after_120_seconds_of_wandering() -> None:
    seen, pad = labels([IDLE, MOTIVATOR_NAVIGATION, PLAN_OWN_CHOICE] + [WANDER] * 8)
    # the planner runs after the motivator's reward and its own D+0.1: still unconcerned
    assert seen[:3] == ["unconcerned"] * 3
    # wander steps 1-7 cross the neutral gap, step 8 (120 s) is elated
    assert seen[3:10] == [NEUTRAL] * 7
    assert seen[10] == "elated"
    assert pad.as_tuple() == pytest.approx((0.11, 0.386, 0.198), abs=0.001)


def test_scenario_a1_needs_the_hysteresis_to_stay_unconcerned_for_the_planner() -> None:
    without = EmotionSettings(hysteresis=0.0)
    # after the motivator's reward the point is 0.441 from unconcerned
    assert labels([IDLE, MOTIVATOR_NAVIGATION], without)[0] == ["unconcerned", NEUTRAL]


def test_scenario_a3_being_bossed_around_makes_the_elated_cyborg_curious() -> None:
    seen, _ = labels([COMMANDED, MOVE, MOVE], start=PAD(0.11, 0.386, 0.198), current="elated")
    assert seen == ["curious"] * 3


def test_scenario_c_scheduled_trip_to_a_pleasant_place_stays_neutral() -> None:
    seen, pad = labels([PLAN_CALENDAR] + [MOVE] * 6 + [PLEASANT_ARRIVAL])
    assert seen == [NEUTRAL] * 8
    assert pad.as_tuple() == pytest.approx((0.10, 0.090, -0.04), abs=0.001)


def test_the_table_threshold_of_0_1_would_never_leave_neutral_while_idle() -> None:
    seen, _ = labels([IDLE] * 30, EmotionSettings(threshold=0.1, hysteresis=0.0))
    assert set(seen) == {NEUTRAL}


def test_a_long_idle_spell_goes_unconcerned_then_sad_then_bored() -> None:
    seen, _ = labels([IDLE] * 12)
    order = [name for i, name in enumerate(seen) if i == 0 or seen[i - 1] != name]
    assert order == ["unconcerned", "inhibited", "bored"]
