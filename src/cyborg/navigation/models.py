"""The navigation module's value types: places, calendar events and sentences, and their own checks.

The bottom of the navigation package: the stores (:mod:`~cyborg.navigation.locations`,
:mod:`~cyborg.navigation.events`, :mod:`~cyborg.navigation.responses`), the calendar logic,
the shipped content and the module all pass these frozen dataclasses around; this module
imports nothing of the navigation package but :mod:`~cyborg.navigation.keywords`.

The checks here look at one value on its own (a name has letters, a pose is finite); the
stores add the checks against other rows (a name is not taken).
"""

from __future__ import annotations

import enum
import math
import re
from dataclasses import dataclass, replace
from datetime import datetime

from cyborg.emotion.model import TABLE_2_2_ALIASES
from cyborg.errors import DatabaseError
from cyborg.navigation.keywords import normalise

PLACEHOLDER = "LOCATION"
"""Word in a response sentence that is replaced by the location's name."""


class ResponseType(enum.Enum):
    """What a sentence is for; some kinds must name the place (contain ``LOCATION``)."""

    OPINION = "opinion"
    ARRIVED = "arrived"
    STUCK = "stuck"
    OFFER_GUIDE = "offer_guide"
    CONFIRM = "confirm"
    REFUSE = "refuse"
    ASK_LOCATION = "ask_location"
    UNKNOWN_LOCATION = "unknown_location"
    DECLINED = "declined"
    NOT_ON_MAP = "not_on_map"
    NO_POSE = "no_pose"
    RESUME = "resume"
    ASK_GO = "ask_go"
    """Asks to confirm a command before setting off (7.7): "Shall I go to the LOCATION?"."""
    DID_YOU_MEAN = "did_you_mean"
    """Asks which place was meant when speech understanding heard it only roughly: "Did you mean the LOCATION?"."""

    @property
    def needs_location(self) -> bool:
        return self in (
            ResponseType.OPINION,
            ResponseType.ARRIVED,
            ResponseType.STUCK,
            ResponseType.NOT_ON_MAP,
            ResponseType.NO_POSE,
            ResponseType.ASK_GO,
            ResponseType.DID_YOU_MEAN,
        )


@dataclass(frozen=True)
class Location:
    """A known place; ``x`` and ``y`` are None while its pose is not known (then it is no target)."""

    name: str
    aliases: tuple[str, ...] = ()
    map: str = ""
    x: float | None = None
    y: float | None = None
    heading: float = 0.0
    tolerance: float = 0.5
    crowded: bool = False
    pleasantness: float = 0.0

    @property
    def position(self) -> tuple[float, float] | None:
        """(x, y) in metres, or None if the place has no pose."""
        return None if self.x is None or self.y is None else (self.x, self.y)


@dataclass(frozen=True)
class CalendarEvent:
    """Be at ``location`` from ``start`` to ``end`` (aware datetimes), maybe recurring."""

    location: str
    start: datetime
    end: datetime
    ignored: bool = False
    recurrence: str | None = None
    summary: str | None = None
    uid: str | None = None
    id: int | None = None


@dataclass(frozen=True)
class Occurrence:
    """One occurrence of a (possibly recurring) calendar event."""

    event: CalendarEvent
    start: datetime
    end: datetime


@dataclass(frozen=True)
class Response:
    """A sentence the robot can say; ``emotion`` None fits every emotion."""

    sentence: str
    type: ResponseType
    emotion: str | None = None
    id: int | None = None

    def say(self, location: str) -> str:
        """The sentence with ``LOCATION`` replaced by ``location``."""
        return self.sentence.replace(PLACEHOLDER, location)


# --- checks of one value ---------------------------------------------------------------------


def valid_location(location: Location) -> Location:
    """``location`` with tidy names and a heading in [-pi, pi]; DatabaseError on bad values."""
    name = " ".join(location.name.split())
    if not normalise(name):
        raise DatabaseError(
            f"location name {location.name!r} has no letters or digits; give a name like 'cafeteria'"
        )
    aliases = tuple(dict.fromkeys(" ".join(a.split()) for a in location.aliases))
    spoken = [normalise(name)]
    for alias in aliases:
        if not normalise(alias):
            raise DatabaseError(
                f"alias {alias!r} of {name!r} has no letters or digits; remove it or spell it out"
            )
        if normalise(alias) in spoken:
            raise DatabaseError(f"alias {alias!r} of {name!r} repeats its name or another alias; remove it")
        spoken.append(normalise(alias))
    for label, value in (("x", location.x), ("y", location.y), ("heading", location.heading)):
        if value is not None and not math.isfinite(value):
            raise DatabaseError(f"{label}={value} of {name!r} is not a finite number; give metres/radians")
    if (location.x is None) != (location.y is None):
        given, missing = ("x", "y") if location.y is None else ("y", "x")
        raise DatabaseError(
            f"{name!r} has {given} but no {missing}; give both (its pose), or neither while the pose is not known"
        )
    if location.x is None and location.map.strip():
        raise DatabaseError(
            f"{name!r} is on map {location.map.strip()!r} but has no x and y; give its pose on that map, "
            "or leave the map out"
        )
    if not (math.isfinite(location.tolerance) and location.tolerance > 0):
        raise DatabaseError(f"tolerance={location.tolerance} of {name!r} must be > 0 m; e.g. 0.5")
    if not -1.0 <= location.pleasantness <= 1.0:
        raise DatabaseError(f"pleasantness={location.pleasantness} of {name!r} is outside -1..1; e.g. 0.5")
    heading = math.remainder(location.heading, 2 * math.pi)
    return replace(location, name=name, aliases=aliases, map=location.map.strip(), heading=heading)


def emotion_key(emotion: str | None) -> str | None:
    """Canonical emotion name (lower case, Table 2.2's bracketed words mapped to its names, so a
    sentence stored for 'happy' by an older version fits 'elated'); None/'' means any emotion."""
    if emotion is None or not emotion.strip():
        return None
    key = "_".join(emotion.strip().lower().split())
    if not re.fullmatch(r"[a-z][a-z0-9_]*", key):
        raise DatabaseError(f"emotion {emotion!r} is not a name; use e.g. elated, angry or curious")
    return TABLE_2_2_ALIASES.get(key, key)


def checked_sentence(response: Response) -> Response:
    """``response`` with its sentence's spaces tidied and its emotion canonical; DatabaseError if
    the sentence is empty or lacks the ``LOCATION`` its type needs."""
    sentence = " ".join(response.sentence.split())
    if not sentence:
        raise DatabaseError("the response sentence is empty; write what the robot should say")
    if response.type.needs_location and PLACEHOLDER not in sentence:
        raise DatabaseError(
            f"{response.type.value} sentence {sentence!r} lacks the placeholder {PLACEHOLDER}; "
            f"write e.g. 'I like the {PLACEHOLDER}'"
        )
    return replace(response, sentence=sentence, emotion=emotion_key(response.emotion))
