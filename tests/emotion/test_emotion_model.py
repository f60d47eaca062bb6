"""PAD update, time decay, emotion naming and feedback validation, against hand-computed values."""

from __future__ import annotations

import math

import pytest
from pydantic import ValidationError

from cyborg.emotion.model import (
    NEUTRAL,
    PAD,
    TABLE_2_2,
    EmotionPrototype,
    EmotionSettings,
    HalfLives,
    InvalidFeedback,
    nearest_emotion,
    time_decay,
    update,
    validate_feedback,
)
from cyborg.errors import CyborgError


def approx(pad: PAD) -> tuple[object, ...]:
    return tuple(pytest.approx(x, abs=1e-12) for x in pad.as_tuple())


# --- update: E - E^3 * r + dE, clamped ------------------------------------------------


def test_update_applies_cubic_decay_then_adds_the_change() -> None:
    # P: 0.5 - 0.5^3 * 0.15 + 0.1     = 0.5 - 0.01875 + 0.1 = 0.58125
    # A: -0.5 - (-0.5)^3 * 0.15 + 0.0 = -0.5 + 0.01875     = -0.48125
    # D: 0.0 - 0 - 0.2                                      = -0.2
    result = update(PAD(0.5, -0.5, 0.0), PAD(0.1, 0.0, -0.2), decay_rate=0.15)
    assert result.as_tuple() == approx(PAD(0.58125, -0.48125, -0.2))


def test_update_clamps_to_the_cube() -> None:
    # P: 0.9 - 0.729 * 0.15 + 0.5 = 1.29065 -> 1.0
    # A: -1 - (-1) * 0.15 - 2.0   = -2.85   -> -1.0
    # D: 0.2 - 0.008 * 0.15 + 0   = 0.1988 (inside, untouched)
    result = update(PAD(0.9, -1.0, 0.2), PAD(0.5, -2.0, 0.0), decay_rate=0.15)
    assert result.as_tuple() == approx(PAD(1.0, -1.0, 0.1988))


def test_update_without_decay_just_adds() -> None:
    assert update(PAD(0.3, 0.3, 0.3), PAD(0.1, -0.1, 0.0), 0.0).as_tuple() == approx(PAD(0.4, 0.2, 0.3))


def test_update_refuses_non_finite_change() -> None:
    with pytest.raises(InvalidFeedback, match="delta_arousal = nan"):
        update(PAD(), PAD(0.0, math.nan, 0.0), 0.15)


# --- time decay -------------------------------------------------------------------------


def test_time_decay_halves_per_half_life_and_skips_dimensions_without_one() -> None:
    # P: 0.8 * 0.5^(10/10) = 0.4;  A: no half-life -> -0.4;  D: 0.2 * 0.5^(10/5) = 0.05
    half_lives = HalfLives(pleasure=10.0, arousal=None, dominance=5.0)
    result = time_decay(PAD(0.8, -0.4, 0.2), 10.0, half_lives)
    assert result.as_tuple() == approx(PAD(0.4, -0.4, 0.05))


def test_time_decay_off_by_default() -> None:
    settings = EmotionSettings()
    assert settings.time_decay_half_lives is None
    assert time_decay(PAD(0.8, -0.4, 0.2), 1e6, None) == PAD(0.8, -0.4, 0.2)


def test_time_decay_ten_small_steps_equal_one_big_step() -> None:
    half_lives = HalfLives(pleasure=3.0, arousal=7.0, dominance=1.5)
    stepwise = PAD(0.9, -0.6, 0.3)
    for _ in range(10):
        stepwise = time_decay(stepwise, 1.0, half_lives)
    once = time_decay(PAD(0.9, -0.6, 0.3), 10.0, half_lives)
    assert stepwise.as_tuple() == approx(once)
    # and it really decayed: 0.9 * 0.5^(10/3) = 0.0893...
    assert once.pleasure == pytest.approx(0.9 * 0.5 ** (10 / 3))


@pytest.mark.parametrize("elapsed", [-1.0, math.nan, math.inf])
def test_time_decay_rejects_bad_elapsed(elapsed: float) -> None:
    with pytest.raises(ValueError, match="elapsed_seconds"):
        time_decay(PAD(0.5, 0.5, 0.5), elapsed, HalfLives(pleasure=1.0))


# --- nearest emotion ----------------------------------------------------------------------


def table() -> list[EmotionPrototype]:
    return EmotionSettings().emotion_prototypes


def test_prototype_point_is_named_after_itself() -> None:
    for name, point in TABLE_2_2.items():
        assert nearest_emotion(PAD.of(point), table(), 0.4) == name


def test_origin_is_neutral_because_nearest_prototype_is_beyond_threshold() -> None:
    # nearest is unconcerned: sqrt(0.13^2 + 0.41^2 + 0.08^2) = sqrt(0.1914) = 0.4375 > 0.4
    assert nearest_emotion(PAD(), table(), 0.4) == NEUTRAL
    assert nearest_emotion(PAD(), table(), 0.44) == "unconcerned"


def test_threshold_decides_between_prototype_and_neutral() -> None:
    # (-0.05,-0.05,-0.05) to unconcerned (-0.13,-0.41,0.08):
    # sqrt(0.08^2 + 0.36^2 + 0.13^2) = sqrt(0.0064 + 0.1296 + 0.0169) = sqrt(0.1529) = 0.39102
    point = PAD(-0.05, -0.05, -0.05)
    assert nearest_emotion(point, table(), 0.40) == "unconcerned"
    assert nearest_emotion(point, table(), 0.39) == NEUTRAL


TWO = [EmotionPrototype("a", PAD(0.0, 0.0, 0.0)), EmotionPrototype("b", PAD(0.4, 0.0, 0.0))]


def test_hysteresis_keeps_current_until_rival_is_closer_by_the_margin() -> None:
    # at x = 0.22: |a| = 0.22, |b| = 0.18 -> b is closer by 0.04 < 0.05
    assert nearest_emotion(PAD(0.22, 0, 0), TWO, 0.3) == "b"
    assert nearest_emotion(PAD(0.22, 0, 0), TWO, 0.3, current="a", hysteresis=0.05) == "a"
    # at x = 0.25: |a| = 0.25, |b| = 0.15 -> closer by 0.10 > 0.05, b takes over
    assert nearest_emotion(PAD(0.25, 0, 0), TWO, 0.3, current="a", hysteresis=0.05) == "b"


def test_hysteresis_holds_current_a_margin_past_the_threshold() -> None:
    # at x = -0.33: |a| = 0.33 > 0.3 but <= 0.3 + 0.05, so a held; fresh it is neutral
    assert nearest_emotion(PAD(-0.33, 0, 0), TWO, 0.3) == NEUTRAL
    assert nearest_emotion(PAD(-0.33, 0, 0), TWO, 0.3, current="a", hysteresis=0.05) == "a"
    # at x = -0.36: |a| = 0.36 > 0.35 -> let go
    assert nearest_emotion(PAD(-0.36, 0, 0), TWO, 0.3, current="a", hysteresis=0.05) == NEUTRAL


def test_hysteresis_does_not_let_a_prototype_in_from_neutral_early() -> None:
    # |a| = 0.33: inside threshold + margin, but neutral -> a needs <= threshold
    assert nearest_emotion(PAD(-0.33, 0, 0), TWO, 0.3, current=NEUTRAL, hysteresis=0.05) == NEUTRAL


def test_ties_go_to_the_alphabetically_first_name() -> None:
    twins = [EmotionPrototype("zeta", PAD(0.1, 0, 0)), EmotionPrototype("alpha", PAD(-0.1, 0, 0))]
    assert nearest_emotion(PAD(), twins, 0.2) == "alpha"


def test_no_prototypes_is_neutral() -> None:
    assert nearest_emotion(PAD(0.5, 0.5, 0.5), [], 1.0) == NEUTRAL


# --- feedback validation --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("delta", "needle"),
    [
        (PAD(math.nan, 0, 0), "delta_pleasure = nan"),
        (PAD(0, math.inf, 0), "delta_arousal = inf"),
        (PAD(0, 0, -2.5), "delta_dominance = -2.5"),
    ],
)
def test_bad_feedback_is_rejected_naming_the_value(delta: PAD, needle: str) -> None:
    with pytest.raises(InvalidFeedback, match=needle) as info:
        validate_feedback(delta, 2.0)
    assert isinstance(info.value, CyborgError)


def test_feedback_at_the_limit_is_accepted() -> None:
    assert validate_feedback(PAD(2.0, -2.0, 0.05), 2.0) == PAD(2.0, -2.0, 0.05)


# --- settings -------------------------------------------------------------------------------


def test_default_settings_follow_the_spec() -> None:
    s = EmotionSettings()
    assert (s.decay_rate, s.threshold, s.max_feedback_magnitude) == (0.15, 0.4, 2.0)
    assert set(s.prototypes) == {
        "angry",
        "bored",
        "curious",
        "dignified",
        "elated",
        "inhibited",
        "puzzled",
        "loved",
        "unconcerned",
    }
    assert s.prototypes["elated"] == (0.50, 0.42, 0.23)


@pytest.mark.parametrize(
    ("data", "needle"),
    [
        ({"treshold": 0.3}, "treshold"),
        ({"threshold": 0.0}, "threshold"),
        ({"decay_rate": -0.1}, "decay_rate"),
        ({"prototypes": {}}, "prototypes is empty"),
        ({"prototypes": {"neutral": (0, 0, 0)}}, "reserved"),
        ({"prototypes": {"joy": (0.5, 1.5, 0)}}, "'joy' has arousal = 1.5"),
        ({"time_decay_half_lives": {"pleasure": 0}}, "pleasure"),
    ],
)
def test_bad_settings_are_explained(data: dict[str, object], needle: str) -> None:
    with pytest.raises(ValidationError, match=needle):
        EmotionSettings.model_validate(data)


def test_settings_accept_yaml_style_lists() -> None:
    s = EmotionSettings.model_validate(
        {"prototypes": {"calm": [0.2, -0.3, 0.1]}, "time_decay_half_lives": {"arousal": 60}}
    )
    assert s.emotion_prototypes == [EmotionPrototype("calm", PAD(0.2, -0.3, 0.1))]
    assert s.time_decay_half_lives == HalfLives(arousal=60.0)
