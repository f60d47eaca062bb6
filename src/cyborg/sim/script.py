"""Scenario scripts: a timeline of inputs for the simulated robot, and its validation.

A script (YAML) gives an optional start date-time (UTC unless it carries an offset such
as ``+01:00``; by default 2026-11-23 09:00 UTC), seed, initial emotion and calendar, an end time ``until`` and ``steps``. A step waits (``at`` a virtual
time, or ``when`` a transcript record matches, plus an optional ``delay``) and
then acts (``say`` text as speech-to-text, publish an ``event``, or set the
``emotion``). An ``expect`` step checks instead: a matching record must come after the
previous step (``within`` seconds, or before the end), else the run fails naming the step's
line and what happened instead; so does a ``when`` that never matches. An ``expect_not`` step
checks the other way: no matching record may come in its window (``within`` seconds after the
previous step, or until the end), else the run fails naming the record that came. Errors name
the line and the fix.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from cyborg.configfile import describe_errors, item_lines, load_yaml, read_text_file
from cyborg.errors import ConfigError, InvalidValueError
from cyborg.limits import MAX_SCRIPT_SECONDS, MAX_TEXT_LENGTH

RECORD_TYPES = ("state", "emotion", "say", "heard", "pose", "motivator")
_HMS = re.compile(r"^(\d+):([0-5]\d):([0-5]\d(?:\.\d+)?)$")


def parse_seconds(value: Any) -> float:
    """Seconds from a number or "H:MM:SS", at most :data:`~cyborg.limits.MAX_SCRIPT_SECONDS`.

    Raises :class:`~cyborg.errors.InvalidValueError` (a ValueError) naming the value and the fix.
    """
    if isinstance(value, bool):
        raise InvalidValueError(f"{value!r} is not a time; fix: use seconds (90) or H:MM:SS (0:01:30)")
    seconds: float | None = None
    if isinstance(value, float) and math.isnan(value):
        raise InvalidValueError(f"{value!r} is not a time; fix: use seconds (90) or H:MM:SS (0:01:30)")
    if isinstance(value, int | float):
        if value < 0:
            raise InvalidValueError(f"{value} is negative (times count from the start); fix: use 0 or more")
        seconds = float(value) if value <= MAX_SCRIPT_SECONDS else math.inf
    elif isinstance(value, str):
        match = _HMS.match(value.strip())
        if match:
            hours, minutes, secs = match.groups()
            seconds = int(hours) * 3600 + int(minutes) * 60 + float(secs) if len(hours) < 10 else math.inf
    if seconds is None or math.isnan(seconds):
        raise InvalidValueError(f"{value!r} is not a time; fix: use seconds (90) or H:MM:SS (0:01:30)")
    if seconds > MAX_SCRIPT_SECONDS:
        raise InvalidValueError(
            f"{value!r} is over the limit of {MAX_SCRIPT_SECONDS:.0f} s (366 days); "
            "fix: use a finite time within a year, e.g. 604800 for a week"
        )
    return seconds


class Match(BaseModel):
    """A transcript record to wait for: its type, plus text it contains and/or field values."""

    model_config = ConfigDict(extra="allow")

    type: str
    contains: str | None = Field(None, max_length=MAX_TEXT_LENGTH)

    @field_validator("type")
    @classmethod
    def _known_type(cls, value: str) -> str:
        if value not in RECORD_TYPES:
            raise InvalidValueError(
                f"unknown record type {value!r}; fix: use one of {', '.join(RECORD_TYPES)}"
            )
        return value

    @model_validator(mode="after")
    def _plain_fields(self) -> Match:
        for key, value in (self.model_extra or {}).items():
            if not isinstance(value, str | int | float | bool) or len(str(value)) > MAX_TEXT_LENGTH:
                raise InvalidValueError(
                    f"field {key!r} must be one short value (text, a number, true or false), "
                    f"not {type(value).__name__} {str(value)[:40]!r}; fix: e.g. {{type: state, to: idle}}"
                )
        return self

    def matches(self, record: dict[str, Any]) -> bool:
        if record.get("type") != self.type:
            return False
        if self.contains is not None:
            haystack = " ".join(str(v) for k, v in record.items() if k not in ("t", "t_ns", "type")).lower()
            if self.contains.lower() not in haystack:
                return False
        extra = self.model_extra or {}
        return all(str(record.get(key)) == str(value) for key, value in extra.items())

    def describe(self) -> str:
        """As written in a script: ``{type: state, to: idle}``."""
        fields = {
            "type": self.type,
            **({"contains": self.contains} if self.contains else {}),
            **(self.model_extra or {}),
        }
        return "{" + ", ".join(f"{key}: {value}" for key, value in fields.items()) + "}"


class Step(BaseModel):
    model_config = ConfigDict(extra="forbid")

    at: float | None = None
    when: Match | None = None
    delay: float = 0.0
    say: str | None = Field(
        None, max_length=MAX_TEXT_LENGTH, description="what the robot hears, one sentence at a time"
    )
    event: str | None = Field(None, max_length=200)
    emotion: str | None = Field(None, max_length=200)
    expect: Match | None = Field(
        None, description="a record that must come after the previous step, else the run fails"
    )
    expect_not: Match | None = Field(
        None, description="a record that must not come within the window after the previous step"
    )
    within: float | None = Field(
        None,
        description="with expect: seconds it may take; with expect_not: the window (default: until the end)",
    )
    line: int = Field(0, exclude=True)

    @field_validator("at", "delay", "within", mode="before")
    @classmethod
    def _time(cls, value: Any) -> float | None:
        return None if value is None else parse_seconds(value)

    @model_validator(mode="after")
    def _one_trigger_one_action(self) -> Step:
        actions = [a for a in ("say", "event", "emotion") if getattr(self, a) is not None]
        if self.expect is not None and self.expect_not is not None:
            raise InvalidValueError(
                "a step takes 'expect' or 'expect_not', not both; fix: make them two steps"
            )
        check = "expect" if self.expect is not None else "expect_not" if self.expect_not is not None else None
        if check is not None:
            extra = [k for k in ("at", "when", *actions) if getattr(self, k) is not None] + (
                ["delay"] if self.delay else []
            )
            if extra:
                raise InvalidValueError(
                    f"an {check!r} step only checks, so it takes no {', '.join(repr(k) for k in extra)}; "
                    f"fix: put the action in a step of its own, e.g. - {check}: {{type: state, to: idle}}"
                )
            return self
        if self.within is not None:
            raise InvalidValueError(
                "'within' goes with 'expect' or 'expect_not'; "
                "fix: e.g. - {expect: {type: say, contains: cafeteria}, within: 30}"
            )
        if (self.at is None) == (self.when is None):
            raise InvalidValueError(
                "give exactly one of 'at' (a time) or 'when' (a record to wait for); "
                "fix: e.g. at: 10, or when: {type: state, to: idle}"
            )
        if len(actions) != 1:
            raise InvalidValueError(
                f"give exactly one action of 'say', 'event' or 'emotion', not {len(actions)}; "
                "fix: one action per step, e.g. say: hello (add a step for the next one)"
            )
        return self


class CalendarEntry(BaseModel):
    model_config = ConfigDict(extra="forbid")

    location: str = Field(examples=["cafeteria"])
    start: datetime = Field(examples=["2026-11-23T15:00:00"])
    end: datetime = Field(examples=["2026-11-23T16:00:00"])
    recurrence: str | None = None
    ignore: bool = False
    line: int = Field(0, exclude=True)

    @model_validator(mode="after")
    def _ends_after_start(self) -> CalendarEntry:
        if (self.start.tzinfo is None) != (self.end.tzinfo is None):
            naive, aware = ("start", "end") if self.start.tzinfo is None else ("end", "start")
            raise InvalidValueError(
                f"{naive} has no time zone but {aware} has one; fix: give both an offset "
                "(e.g. 2026-11-23T15:00:00+01:00) or neither (then they are read in UTC)"
            )
        if self.end <= self.start:
            raise InvalidValueError(
                f"end {self.end.isoformat()} is not after start {self.start.isoformat()}; fix: swap them"
            )
        return self


class Script(BaseModel):
    model_config = ConfigDict(extra="forbid")

    start: datetime | None = Field(
        None, description="virtual date-time at t = 0; UTC unless it carries an offset (+01:00)"
    )
    seed: int = 0
    emotion: str | None = None
    calendar: list[CalendarEntry] = Field(default_factory=list)
    until: float = Field(examples=[600])
    steps: list[Step] = Field(default_factory=list)
    source: str = Field("<script>", exclude=True)  # the file, for error messages

    @field_validator("until", mode="before")
    @classmethod
    def _until(cls, value: Any) -> float:
        return parse_seconds(value)


def check_against(script: Script, events: set[str], emotions: set[str]) -> None:
    """Refuse steps that a robot with these events and emotion names could not act on.

    A misspelt event would be dropped by the controller and a misspelt emotion rejected by the
    emotion system, so the run would end without doing what the script meant.
    """
    problems: list[str] = []
    known_events = ", ".join(sorted(events))
    known_emotions = ", ".join(sorted(emotions))
    if script.emotion is not None and script.emotion not in emotions:
        problems.append(
            f"emotion: {script.emotion!r} is no emotion of this robot; fix: use one of {known_emotions}"
        )
    for number, step in enumerate(script.steps, start=1):
        where = f"line {step.line or '?'}: step {number}"
        if step.event is not None and step.event not in events:
            problems.append(
                f"{where}: event {step.event!r} is no transition of this state machine; "
                f"fix: use one of {known_events}"
            )
        if step.emotion is not None and step.emotion not in emotions:
            problems.append(
                f"{where}: {step.emotion!r} is no emotion of this robot; fix: use one of {known_emotions}"
            )
    if problems:
        raise ConfigError(problems, source=script.source)


def load_script(path: str | Path) -> Script:
    path = Path(path)
    try:
        text = read_text_file(path)
    except OSError as exc:
        raise ConfigError(
            f"cannot read the script: {exc.strerror}; fix: check the path", source=str(path)
        ) from exc
    return parse_script(text, source=str(path))


def parse_script(text: str, source: str = "<script>") -> Script:
    data = load_yaml(text, source)
    if not isinstance(data, dict):
        raise ConfigError(
            "a script is a mapping with 'until' and 'steps'; fix: see the README's scenario section",
            source=source,
        )
    lines = {key: item_lines(text, key) for key in ("steps", "calendar")}
    try:
        script = Script.model_validate(data)
    except ValidationError as exc:
        problems = describe_errors(
            exc, Script, name=lambda loc: _name(loc, lines), doc="the README's scenario section"
        )
        raise ConfigError(problems, source=source) from exc
    for step, line in zip(script.steps, lines["steps"], strict=False):
        step.line = line
    for entry, line in zip(script.calendar, lines["calendar"], strict=False):
        entry.line = line
    script.source = source
    return script


def _name(loc: Sequence[Any], lines: dict[str, list[int]]) -> str:
    """('steps', 1, 'say') -> 'line 5: step 2 say' (the step's line in the file)."""
    if len(loc) >= 2 and loc[0] in lines and isinstance(loc[1], int):
        known = lines[loc[0]]
        line = known[loc[1]] if loc[1] < len(known) else "?"
        what = "step" if loc[0] == "steps" else "calendar entry"
        rest = ".".join(str(p) for p in loc[2:])
        return f"line {line}: {what} {loc[1] + 1}" + (f" {rest}" if rest else "")
    return ".".join(str(p) for p in loc) or "top level"
