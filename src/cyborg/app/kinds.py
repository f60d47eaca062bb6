"""Module kinds that the YAML's ``modules:`` section can start, each with validated settings.

A kind is a settings model (pydantic, unknown keys rejected) plus a factory that
builds the component on its own node. New kinds register in :data:`MODULE_KINDS`.
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from cyborg.errors import ConfigError
from cyborg.modules.conversation import (
    ANSWERED_FEEDBACK,
    UNANSWERED_FEEDBACK,
    ConversationModule,
    QuestionModule,
)
from cyborg.modules.event_script import EventScript
from cyborg.modules.idle import IdleModule, IdleSettings
from cyborg.modules.music import MUSIC_FEEDBACK, MusicModule
from cyborg.modules.placeholder import PlaceholderModule, PlaceholderSpec
from cyborg.modules.speech import TextToSpeech
from cyborg.transport.base import Node


class BuildContext(Protocol):
    """What module factories may use besides their node: data folder, randomness, the map."""

    data_dir: Path
    rng: random.Random
    calendar: Callable[[Any], None] | None

    def occupancy_map(self) -> Any: ...


class KindSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")
    kind: str


class PlaceholderServer(BaseModel):
    model_config = ConfigDict(extra="forbid")
    action: str
    say: str = ""
    duration: float | None = Field(None, ge=0)
    emotion: tuple[float, float, float] | None = None
    honour_cancel: bool = True


class PlaceholderSettings(KindSettings):
    servers: list[PlaceholderServer] = Field(min_length=1)


class EventScriptSettings(KindSettings):
    events: list[str] = Field(min_length=1)
    every: float = Field(10.0, gt=0)


class IdleKindSettings(KindSettings):
    action: str = "cyborg_idle/idle"
    interval: float = Field(IdleSettings.interval, gt=0)
    boredom: tuple[float, float, float] = IdleSettings.boredom


class ConversationSettings(KindSettings):
    action: str = "cyborg_conversation/conversation"
    quiet_seconds: float = Field(90.0, gt=0)


class QuestionSettings(KindSettings):
    action: str
    question: str = Field(min_length=1)
    answer_seconds: float = Field(6.0, ge=0)
    unanswered_feedback: tuple[float, float, float] = UNANSWERED_FEEDBACK
    answered_feedback: tuple[float, float, float] = ANSWERED_FEEDBACK


class MusicSettings(KindSettings):
    action: str = "cyborg_music/play"
    play_audio: bool | None = None
    feedback: tuple[float, float, float] = MUSIC_FEEDBACK


class TtsSettings(KindSettings):
    queue_size: int = Field(10, ge=1)
    play_audio: bool | None = None
    wav_dir: str | None = None
    voice: str = "en"


class NavigationSettings(KindSettings):
    db: str | None = Field(None, description="navigation database (default: <data dir>/navigation.db)")
    scheduler_interval: float = Field(10.0, gt=0)
    scheduler_repeat: float = Field(20.0, gt=0)
    answer_timeout: float = Field(20.0, gt=0)
    feedback_interval: float = Field(15.0, gt=0)
    wander_limit: float = Field(600.0, gt=0)


class BaseSettings(KindSettings):
    speed: float = Field(0.6, gt=0, description="driving speed in m/s")
    robot_radius: float = Field(0.35, ge=0)
    start: str | None = Field(
        None, description="named pose to start at (default: the information desk, else RobotHome or Dock)"
    )


@dataclass(frozen=True)
class ModuleKind:
    settings: type[KindSettings]
    build: Callable[[Node, Any, BuildContext], object]


def _placeholder(node: Node, s: PlaceholderSettings, robot: BuildContext) -> object:
    return PlaceholderModule(node, [PlaceholderSpec(**server.model_dump()) for server in s.servers])


def _tts(node: Node, s: TtsSettings, robot: BuildContext) -> object:
    from pathlib import Path

    wav_dir = Path(s.wav_dir) if s.wav_dir else None
    return TextToSpeech(
        node, queue_size=s.queue_size, play_audio=s.play_audio, wav_dir=wav_dir, voice=s.voice
    )


def _navigation(node: Node, s: NavigationSettings, robot: BuildContext) -> object:
    from pathlib import Path

    from cyborg.navigation.database import CalendarEvent, NavigationDatabase
    from cyborg.navigation.module import NavigationModule

    db = NavigationDatabase(Path(s.db) if s.db else robot.data_dir / "navigation.db")
    occupancy = robot.occupancy_map()
    map_name = Path(occupancy.source).stem if occupancy.source else "map"
    db.use_map(map_name)  # also for a map without goals: the last map's places are not on this one
    goals = [p for p in occupancy.poses if p.kind in ("Goal", "GoalWithHeading")]
    for goal in goals:
        db.import_pose(goal, map_name)

    def add_calendar_entry(entry: Any) -> None:
        from datetime import UTC

        start, end = (t if t.tzinfo else t.replace(tzinfo=UTC) for t in (entry.start, entry.end))
        db.add_event(
            CalendarEvent(entry.location, start, end, ignored=entry.ignore, recurrence=entry.recurrence)
        )

    robot.calendar = add_calendar_entry
    return NavigationModule(
        node,
        db,
        rng=robot.rng,
        scheduler_interval=s.scheduler_interval,
        scheduler_repeat=s.scheduler_repeat,
        answer_timeout=s.answer_timeout,
        feedback_interval=s.feedback_interval,
        wander_limit=s.wander_limit,
    )


def _simulated_base(node: Node, s: BaseSettings, robot: BuildContext) -> object:
    from cyborg.sim.base import SimulatedBase

    occupancy = robot.occupancy_map()
    start = occupancy.pose(s.start) if s.start else None
    return SimulatedBase(
        node, occupancy, rng=robot.rng, speed=s.speed, robot_radius=s.robot_radius, start=start
    )


MODULE_KINDS: dict[str, ModuleKind] = {
    "navigation": ModuleKind(NavigationSettings, _navigation),
    "simulated_base": ModuleKind(BaseSettings, _simulated_base),
    "placeholder": ModuleKind(PlaceholderSettings, _placeholder),
    "event_script": ModuleKind(EventScriptSettings, lambda n, s, r: EventScript(n, s.events, s.every)),
    "idle": ModuleKind(
        IdleKindSettings,
        lambda n, s, r: IdleModule(n, IdleSettings(interval=s.interval, boredom=s.boredom), action=s.action),
    ),
    "conversation": ModuleKind(
        ConversationSettings,
        lambda n, s, r: ConversationModule(n, quiet_seconds=s.quiet_seconds, action=s.action),
    ),
    "question": ModuleKind(
        QuestionSettings,
        lambda n, s, r: QuestionModule(
            n,
            action=s.action,
            question=s.question,
            answer_seconds=s.answer_seconds,
            unanswered_feedback=s.unanswered_feedback,
            answered_feedback=s.answered_feedback,
        ),
    ),
    "music": ModuleKind(
        MusicSettings,
        lambda n, s, r: MusicModule(
            n, action=s.action, tune_dir=r.data_dir, play_audio=s.play_audio, feedback=s.feedback
        ),
    ),
    "tts": ModuleKind(TtsSettings, _tts),
}


def parse_module_settings(
    node_name: str, raw: Any, kinds: dict[str, ModuleKind], source: str
) -> tuple[ModuleKind, KindSettings]:
    """Validate one ``modules:`` entry; errors name the module and the fix."""
    if not isinstance(raw, dict) or "kind" not in raw:
        raise ConfigError(
            f"module {node_name!r}: needs 'kind:' (one of {', '.join(sorted(kinds))})", source=source
        )
    kind = kinds.get(str(raw["kind"]))
    if kind is None:
        raise ConfigError(
            f"module {node_name!r}: unknown kind {raw['kind']!r}; fix: use one of {', '.join(sorted(kinds))}",
            source=source,
        )
    try:
        return kind, kind.settings.model_validate(raw)
    except ValidationError as exc:
        problems = [_module_problem(node_name, kind.settings, e) for e in exc.errors()]
        raise ConfigError(problems, source=source) from exc


def _module_problem(node_name: str, settings: type[BaseModel], error: Any) -> str:
    """One settings error of module ``node_name``: where, what is wrong and the fix."""
    loc = [str(p) for p in error["loc"]]
    where = f"module {node_name!r} > {'.'.join(loc)}"
    if error["type"] == "extra_forbidden":
        known = ", ".join(name for name in settings.model_fields if name != "kind")
        return f"{where}: unknown setting; fix: remove it or use one of {known}"
    field = settings.model_fields.get(loc[0]) if loc else None
    meaning = f" ({field.description})" if field is not None and field.description else ""
    message = str(error["msg"]).removeprefix("Value error, ")
    if field is None:
        return f"{where}: {message}"
    expected = _READABLE_TYPES.get(str(error["type"]).split("_")[0], "value of the right type")
    value = error.get("input")
    return f"{where}: {message} (got {value!r}); fix: give {expected}{meaning}"


_READABLE_TYPES = {
    "float": "a number, e.g. 2.5",
    "int": "a whole number, e.g. 3",
    "bool": "true or false",
    "string": "text in quotes",
    "greater": "a larger number",
    "less": "a smaller number",
    "list": "a list, e.g. [a, b]",
    "dict": "a mapping, e.g. {key: value}",
}
