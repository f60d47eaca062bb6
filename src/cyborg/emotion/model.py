"""The PAD emotion model: pure functions for the controller core's emotion system.

The Cyborg's mood is a point in the pleasure-arousal-dominance (PAD) cube
[-1, 1]^3. Modules send changes (feedback); :func:`update` adds them after a
cubic decay towards the origin, :func:`time_decay` optionally pulls the point
back to the origin as time passes, and :func:`nearest_emotion` names the point
after the closest emotion prototype within a threshold (``neutral`` otherwise).

Nothing here does I/O or reads a clock: time comes in as seconds. The runtime
that subscribes to topics and publishes states lives elsewhere and calls these.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from cyborg.errors import CyborgError, InvalidValueError

NEUTRAL = "neutral"
"""The name used when no prototype lies within the threshold."""

DIMENSIONS = ("pleasure", "arousal", "dominance")


class InvalidFeedback(CyborgError):
    """A PAD change from a module was NaN, infinite or larger than allowed."""


class UnknownEmotion(CyborgError, ValueError):
    """A typed emotion name is neither an emotion nor an alias of one."""


@dataclass(frozen=True)
class PAD:
    """A point (or a change) in pleasure-arousal-dominance space."""

    pleasure: float = 0.0
    arousal: float = 0.0
    dominance: float = 0.0

    def as_tuple(self) -> tuple[float, float, float]:
        return (self.pleasure, self.arousal, self.dominance)

    def distance(self, other: PAD) -> float:
        """Euclidean distance: the least-squares match of the spec."""
        return math.dist(self.as_tuple(), other.as_tuple())

    @classmethod
    def of(cls, values: Iterable[float]) -> PAD:
        p, a, d = values
        return cls(float(p), float(a), float(d))


@dataclass(frozen=True)
class EmotionPrototype:
    """A named emotion and the PAD point that defines it."""

    name: str
    pad: PAD


# Table 2.2 of the spec (Mehrabian's values) under the table's names, which go on every wire.
TABLE_2_2: dict[str, tuple[float, float, float]] = {
    "angry": (-0.51, 0.59, 0.25),
    "bored": (-0.65, -0.62, -0.33),
    "curious": (0.22, 0.62, -0.10),
    "dignified": (0.55, 0.22, 0.61),
    "elated": (0.50, 0.42, 0.23),
    "inhibited": (-0.54, -0.04, -0.33),
    "puzzled": (-0.41, 0.48, -0.33),
    "loved": (0.89, 0.54, -0.18),
    "unconcerned": (-0.13, -0.41, 0.08),
}

TABLE_2_2_ALIASES: dict[str, str] = {
    "happy": "elated",
    "sad": "inhibited",
    "sadness": "inhibited",
    "surprised": "puzzled",
}
"""The table's bracketed words: accepted wherever a person types an emotion, never published."""


class HalfLives(BaseModel):
    """Seconds after which time decay has halved each dimension; None leaves it alone."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    pleasure: float | None = Field(None, gt=0)
    arousal: float | None = Field(None, gt=0)
    dominance: float | None = Field(None, gt=0)

    def as_tuple(self) -> tuple[float | None, float | None, float | None]:
        return (self.pleasure, self.arousal, self.dominance)


class EmotionSettings(BaseModel):
    """The ``emotion:`` section of the controller's YAML configuration."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    decay_rate: float = Field(0.15, ge=0.0, le=1.0, description="r in E - E^3 * r")
    threshold: float = Field(
        0.40, gt=0.0, description="largest PAD distance at which a prototype still names the mood"
    )
    hysteresis: float = Field(
        0.05, ge=0.0, description="how much closer a rival prototype must be to take over"
    )
    prototypes: dict[str, tuple[float, float, float]] = Field(default_factory=lambda: dict(TABLE_2_2))
    aliases: dict[str, str] = Field(
        default_factory=lambda: dict(TABLE_2_2_ALIASES),
        description="other words a person may type for an emotion (alias: name)",
    )
    time_decay_half_lives: HalfLives | None = None
    max_feedback_magnitude: float = Field(
        2.0, gt=0.0, description="largest |change| accepted per dimension in one feedback"
    )
    resume_within_seconds: float = Field(
        300.0,
        ge=0.0,
        description="a controller restarted on its own (cyborg node cyborg_controller) resumes the stored "
        "emotion if it was stored at most this long ago; 0 never resumes. Every fresh start is neutral.",
    )

    @field_validator("prototypes")
    @classmethod
    def _check_prototypes(
        cls, value: dict[str, tuple[float, float, float]]
    ) -> dict[str, tuple[float, float, float]]:
        if not value:
            raise InvalidValueError(
                "prototypes is empty: list at least one emotion, e.g. elated: [0.5, 0.42, 0.23]"
            )
        for name, point in value.items():
            if not name.strip() or name != name.strip():
                raise InvalidValueError(f"prototype name {name!r} is blank or padded: use e.g. 'elated'")
            if name == NEUTRAL:
                raise InvalidValueError(
                    f"prototype {NEUTRAL!r} is reserved for 'no emotion within threshold': remove it"
                )
            for dim, x in zip(DIMENSIONS, point, strict=True):
                if not (math.isfinite(x) and -1.0 <= x <= 1.0):
                    raise InvalidValueError(
                        f"prototype {name!r} has {dim} = {x}: PAD values must lie in [-1, 1]"
                    )
        return value

    @model_validator(mode="after")
    def _check_aliases(self) -> EmotionSettings:
        if "aliases" not in self.model_fields_set:
            return self  # the table's defaults; those naming no configured prototype are unused
        for alias, name in self.aliases.items():
            if name != NEUTRAL and name not in self.prototypes:
                known = ", ".join([NEUTRAL, *self.prototypes])
                raise InvalidValueError(
                    f"alias {alias!r} names {name!r}, which is no emotion: use one of {known}"
                )
            if alias in self.prototypes:
                raise InvalidValueError(f"alias {alias!r} is also a prototype's name: remove the alias")
        return self

    def resolve(self, name: str) -> str:
        """The emotion a typed ``name`` means (case and spaces ignored, aliases followed).

        Raises :class:`UnknownEmotion` listing the names and aliases a person may use.
        """
        key = "_".join(name.strip().lower().split())
        if key not in self.prototypes:
            key = self.usable_aliases().get(key, key)
        if key == NEUTRAL or key in self.prototypes:
            return key
        aliases = self.usable_aliases()
        also = f" (or {', '.join(f'{a} for {n}' for a, n in sorted(aliases.items()))})" if aliases else ""
        raise UnknownEmotion(f"unknown emotion {name!r}; use one of {', '.join(self.known_names())}{also}")

    def known_names(self) -> list[str]:
        """neutral and every prototype's name, as published."""
        return [NEUTRAL, *sorted(self.prototypes)]

    def usable_aliases(self) -> dict[str, str]:
        """The aliases that name a configured emotion and are no emotion's own name."""
        return {
            alias: name
            for alias, name in self.aliases.items()
            if alias not in self.prototypes and (name == NEUTRAL or name in self.prototypes)
        }

    @property
    def emotion_prototypes(self) -> list[EmotionPrototype]:
        return [EmotionPrototype(name, PAD.of(p)) for name, p in self.prototypes.items()]


def clamp(x: float) -> float:
    return max(-1.0, min(1.0, x))


def validate_feedback(delta: PAD, max_magnitude: float) -> PAD:
    """Return ``delta`` unchanged, or raise :class:`InvalidFeedback` naming the bad value."""
    for dim, x in zip(DIMENSIONS, delta.as_tuple(), strict=True):
        if not math.isfinite(x):
            raise InvalidFeedback(
                f"emotional feedback delta_{dim} = {x} is not a finite number: send a change such as 0.05"
            )
        if abs(x) > max_magnitude:
            raise InvalidFeedback(
                f"emotional feedback delta_{dim} = {x} is larger than the allowed "
                f"{max_magnitude}: send smaller steps (typical feedback is about 0.05)"
            )
    return delta


def update(pad: PAD, delta: PAD, decay_rate: float) -> PAD:
    """One feedback step: E_next = E - E^3 * r + dE per dimension, clamped to [-1, 1]."""
    for dim, x in zip(DIMENSIONS, delta.as_tuple(), strict=True):
        if not math.isfinite(x):
            raise InvalidFeedback(f"delta_{dim} = {x} is not finite: validate feedback first")
    return PAD.of(
        clamp(e - e**3 * decay_rate + d) for e, d in zip(pad.as_tuple(), delta.as_tuple(), strict=True)
    )


def time_decay(pad: PAD, elapsed_seconds: float, half_lives: HalfLives | None) -> PAD:
    """Exponential decay towards 0: each dimension halves every half-life.

    Because the factor is 0.5 ** (elapsed / half_life), decaying by a then by b
    equals decaying by a + b, however often the caller ticks.
    """
    if not (math.isfinite(elapsed_seconds) and elapsed_seconds >= 0.0):
        raise InvalidValueError(
            f"elapsed_seconds = {elapsed_seconds}: pass the non-negative time since the last decay"
        )
    if half_lives is None:
        return pad
    return PAD.of(
        e if h is None else e * 0.5 ** (elapsed_seconds / h)
        for e, h in zip(pad.as_tuple(), half_lives.as_tuple(), strict=True)
    )


def nearest_emotion(
    pad: PAD,
    prototypes: Sequence[EmotionPrototype],
    threshold: float,
    current: str | None = None,
    hysteresis: float = 0.0,
) -> str:
    """Name ``pad`` after the closest prototype within ``threshold``, else ``neutral``.

    Hysteresis (a Schmitt trigger, so the label does not flicker at a border):
    the current emotion is kept while it is within ``threshold + hysteresis``,
    and a rival takes over only if it is within ``threshold`` and closer than the
    current one by more than ``hysteresis``. With ``hysteresis=0`` this is the
    plain nearest-within-threshold rule. Ties go to the alphabetically first name.
    """
    if not prototypes:
        return NEUTRAL
    distances = {p.name: pad.distance(p.pad) for p in prototypes}
    best = min(distances, key=lambda name: (distances[name], name))
    best_distance = distances[best]
    if current is not None and current in distances:
        held = distances[current]
        if held <= threshold + hysteresis:
            if best_distance <= threshold and best_distance < held - hysteresis:
                return best
            return current
    return best if best_distance <= threshold else NEUTRAL
