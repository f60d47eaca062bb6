"""Scenario scripts: a timeline of inputs for the simulated robot, and its validation.

A script (YAML) gives an optional start date-time, seed, initial emotion and
calendar, an end time ``until`` and ``steps``. A step waits (``at`` a virtual
time, or ``when`` a transcript record matches, plus an optional ``delay``) and
then acts (``say`` text as speech-to-text, publish an ``event``, or set the
``emotion``). Errors name the line and the fix.
"""

from __future__ import annotations

import re
from datetime import datetime
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from cyborg.errors import ConfigError

RECORD_TYPES = ("state", "emotion", "say", "heard", "pose", "motivator")
_HMS = re.compile(r"^(\d+):([0-5]\d):([0-5]\d(?:\.\d+)?)$")


def parse_seconds(value: Any) -> float:
    """Seconds from a number or "H:MM:SS"."""
    if isinstance(value, bool):
        raise ValueError(f"{value!r} is not a time; use seconds (90) or H:MM:SS (0:01:30)")
    if isinstance(value, int | float):
        if value < 0:
            raise ValueError(f"{value} is negative; times count from the start, use 0 or more")
        return float(value)
    if isinstance(value, str):
        match = _HMS.match(value.strip())
        if match:
            hours, minutes, seconds = match.groups()
            return int(hours) * 3600 + int(minutes) * 60 + float(seconds)
    raise ValueError(f"{value!r} is not a time; use seconds (90) or H:MM:SS (0:01:30)")


class Match(BaseModel):
    """A transcript record to wait for: its type, plus text it contains and/or field values."""

    model_config = ConfigDict(extra="allow")

    type: str
    contains: str | None = None

    @field_validator("type")
    @classmethod
    def _known_type(cls, value: str) -> str:
        if value not in RECORD_TYPES:
            raise ValueError(f"unknown record type {value!r}; use one of {', '.join(RECORD_TYPES)}")
        return value

    def matches(self, record: dict[str, Any]) -> bool:
        if record.get("type") != self.type:
            return False
        if self.contains is not None:
            haystack = " ".join(str(v) for k, v in record.items() if k not in ("t", "type")).lower()
            if self.contains.lower() not in haystack:
                return False
        extra = self.model_extra or {}
        return all(str(record.get(key)) == str(value) for key, value in extra.items())


class Step(BaseModel):
    model_config = ConfigDict(extra="forbid")

    at: float | None = None
    when: Match | None = None
    delay: float = 0.0
    say: str | None = None
    event: str | None = None
    emotion: str | None = None
    line: int = Field(0, exclude=True)

    @field_validator("at", "delay", mode="before")
    @classmethod
    def _time(cls, value: Any) -> float | None:
        return None if value is None else parse_seconds(value)

    @model_validator(mode="after")
    def _one_trigger_one_action(self) -> Step:
        if (self.at is None) == (self.when is None):
            raise ValueError("give exactly one of 'at' (a time) or 'when' (a record to wait for)")
        actions = [a for a in ("say", "event", "emotion") if getattr(self, a) is not None]
        if len(actions) != 1:
            raise ValueError("give exactly one action: 'say', 'event' or 'emotion'")
        return self


class CalendarEntry(BaseModel):
    model_config = ConfigDict(extra="forbid")

    location: str
    start: datetime
    end: datetime
    recurrence: str | None = None
    ignore: bool = False


class Script(BaseModel):
    model_config = ConfigDict(extra="forbid")

    start: datetime | None = None
    seed: int = 0
    emotion: str | None = None
    calendar: list[CalendarEntry] = Field(default_factory=list)
    until: float
    steps: list[Step] = Field(default_factory=list)

    @field_validator("until", mode="before")
    @classmethod
    def _until(cls, value: Any) -> float:
        return parse_seconds(value)


def _step_lines(text: str) -> list[int]:
    """Line numbers (1-based) of each entry of the top-level ``steps`` list."""
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return []
    if not isinstance(root, yaml.MappingNode):
        return []
    for key, value in root.value:
        if key.value == "steps" and isinstance(value, yaml.SequenceNode):
            return [item.start_mark.line + 1 for item in value.value]
    return []


def load_script(path: str | Path) -> Script:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(
            f"cannot read the script: {exc.strerror}; fix: check the path", source=str(path)
        ) from exc
    return parse_script(text, source=str(path))


def parse_script(text: str, source: str = "<script>") -> Script:
    from cyborg.controller.config import load_yaml

    data = load_yaml(text, source)
    if not isinstance(data, dict):
        raise ConfigError(
            "a script is a mapping with 'until' and 'steps'; fix: see the README's scenario section",
            source=source,
        )
    lines = _step_lines(text)
    try:
        script = Script.model_validate(data)
    except ValidationError as exc:
        raise ConfigError([_describe(error, lines) for error in exc.errors()], source=source) from exc
    for step, line in zip(script.steps, lines, strict=False):
        step.line = line
    return script


def _describe(error: Any, lines: list[int]) -> str:
    loc = list(error["loc"])
    where = "top level"
    if len(loc) >= 2 and loc[0] == "steps" and isinstance(loc[1], int):
        line = lines[loc[1]] if loc[1] < len(lines) else "?"
        rest = ".".join(str(p) for p in loc[2:])
        where = f"line {line}: step {loc[1] + 1}" + (f" {rest}" if rest else "")
    elif loc:
        where = ".".join(str(p) for p in loc)
    message = error["msg"].removeprefix("Value error, ")
    if error["type"] == "extra_forbidden":
        message = f"unknown key {loc[-1]!r}; fix: use at/when/delay and one of say/event/emotion"
    elif error["type"] == "missing":
        message = f"missing {loc[-1]!r}; fix: add it (e.g. until: 600)"
    return f"{where}: {message}"
