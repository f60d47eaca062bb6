"""Hypothesis properties of the PAD model: the mood never leaves the cube, decay composes."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from cyborg.emotion.model import (
    NEUTRAL,
    PAD,
    EmotionSettings,
    HalfLives,
    InvalidFeedback,
    nearest_emotion,
    time_decay,
    update,
    validate_feedback,
)

any_float = st.floats(allow_nan=True, allow_infinity=True)
unit = st.floats(-1.0, 1.0)
pads = st.builds(PAD, unit, unit, unit)
deltas = st.builds(PAD, any_float, any_float, any_float)
half_life = st.one_of(st.none(), st.floats(0.01, 1e4))


@given(st.lists(deltas, max_size=40), st.floats(0.0, 1.0), st.floats(0.01, 100.0))
def test_pad_stays_in_the_cube_for_any_feedback(feedback: list[PAD], rate: float, limit: float) -> None:
    pad = PAD()
    for delta in feedback:
        try:
            validate_feedback(delta, limit)
        except InvalidFeedback:
            continue
        pad = update(pad, delta, rate)
        assert all(-1.0 <= x <= 1.0 for x in pad.as_tuple()), pad


@given(deltas, st.floats(0.01, 100.0))
def test_accepted_feedback_is_finite_and_within_the_limit(delta: PAD, limit: float) -> None:
    try:
        validate_feedback(delta, limit)
    except InvalidFeedback:
        assert any(not math.isfinite(x) or abs(x) > limit for x in delta.as_tuple())
    else:
        assert all(math.isfinite(x) and abs(x) <= limit for x in delta.as_tuple())


@given(pads, st.floats(0.0, 1e4), st.floats(0.0, 1e4), half_life, half_life, half_life)
def test_time_decay_composes(
    pad: PAD, a: float, b: float, hp: float | None, ha: float | None, hd: float | None
) -> None:
    half_lives = HalfLives(pleasure=hp, arousal=ha, dominance=hd)
    twice = time_decay(time_decay(pad, a, half_lives), b, half_lives)
    once = time_decay(pad, a + b, half_lives)
    for x, y in zip(twice.as_tuple(), once.as_tuple(), strict=True):
        assert math.isclose(x, y, rel_tol=1e-9, abs_tol=1e-12)


@given(pads, st.floats(0.0, 1e4), half_life)
def test_time_decay_never_moves_away_from_the_origin(pad: PAD, elapsed: float, h: float | None) -> None:
    decayed = time_decay(pad, elapsed, HalfLives(pleasure=h, arousal=h, dominance=h))
    for before, after in zip(pad.as_tuple(), decayed.as_tuple(), strict=True):
        assert abs(after) <= abs(before)
        assert after * before >= 0.0


@given(pads, st.floats(0.01, 2.0))
def test_a_named_emotion_is_within_the_threshold(pad: PAD, threshold: float) -> None:
    prototypes = EmotionSettings().emotion_prototypes
    name = nearest_emotion(pad, prototypes, threshold)
    distances = {p.name: pad.distance(p.pad) for p in prototypes}
    if name == NEUTRAL:
        assert min(distances.values()) > threshold
    else:
        assert distances[name] <= threshold
        assert distances[name] == min(distances.values())
