"""Load and validate the robot's YAML file: the state machine and its components' sections.

The state machine's part (``initial``, ``timeouts``, ``states``) and its checks live in
:mod:`cyborg.controller.config`; the sections of the emotion system, the motivator, the
modules and the gatekeepers are added here, where every component is known. Reading
and wording problems are :mod:`cyborg.configfile`'s. Every problem names the file, where
in it, what is wrong and the fix. docs/configuration.md describes every key.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from cyborg.configfile import describe_errors, key_lines, load_yaml, read_text_file, suggest, yaml_kind
from cyborg.controller.config import (
    MACHINE_FIXES,
    MACHINE_KEYS,
    MachineModel,
    build_machine,
    name_machine_location,
)
from cyborg.controller.machine import MachineSpec
from cyborg.emotion.model import EmotionSettings
from cyborg.errors import ConfigError
from cyborg.motivator.logic import MotivationalEvent, MotivatorSettings

__all__ = [
    "ConfigModel",
    "GatekeeperModel",
    "LoadedConfig",
    "RecordingModel",
    "check_motivational_events",
    "load_config",
    "packaged_config",
    "parse_config",
]


class GatekeeperModel(BaseModel):
    """A relay in front of an output module: only the node holding ``resource`` gets through."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(min_length=1, description="node name of the gatekeeper", examples=["cyborg_gatekeeper"])
    input: str = Field(
        min_length=1, description="topic the behaviour modules publish on", examples=["/text_to_speech"]
    )
    output: str = Field(
        min_length=1, description="topic the output module listens to", examples=["/cyborg_tts/say"]
    )
    resource: str = Field(
        min_length=1, description="resource name in the states' resource lists", examples=["speech"]
    )


class RecordingModel(BaseModel):
    """The flight recorder: where every run is recorded, and how much disk it may take."""

    model_config = ConfigDict(extra="forbid")

    enabled: bool = Field(True, description="record every run (cyborg sim, scripts) to MCAP")
    folder: str | None = Field(
        None, description="folder of the recordings (default: the data folder's recordings/)"
    )
    budget_mb: float = Field(
        1024.0, gt=0, description="MB the folder may hold; the oldest are deleted beyond"
    )
    segment_minutes: float = Field(60.0, gt=0, description="a new file after this many minutes of robot time")
    segment_mb: float = Field(16.0, gt=0, description="a new file once one holds this many MB")


class ConfigModel(MachineModel):
    """The whole YAML file. Sections other than the state machine belong to their components."""

    model_config = ConfigDict(extra="forbid")

    emotion: EmotionSettings = Field(default_factory=EmotionSettings)  # type: ignore[arg-type]
    motivator: MotivatorSettings = Field(default_factory=MotivatorSettings)  # type: ignore[arg-type]
    navigation: dict[str, Any] = Field(
        default_factory=dict, description="reserved; not read by any component"
    )
    modules: dict[str, Any] = Field(
        default_factory=dict, description="node name: module settings (kind: ...)"
    )
    gatekeepers: list[GatekeeperModel] = Field(default_factory=list)
    recording: RecordingModel = Field(default_factory=RecordingModel)  # type: ignore[arg-type]


@dataclass
class LoadedConfig:
    """A validated configuration: the machine, the raw model and any warnings."""

    machine: MachineSpec
    model: ConfigModel
    source: str
    warnings: list[str] = field(default_factory=list)
    text: str = field(default="", repr=False)
    """The file's text, for the line numbers of messages about its parts (``cyborg validate``)."""

    def where(self, *path: str) -> str:
        """``"line N: "`` for the key at ``path`` (e.g. ``"modules", "greeter"``), or "" if unknown."""
        line = key_lines(self.text).get(path) if self.text else None
        return f"line {line}: " if line is not None else ""


_PROTOTYPE_FIX = (
    "give three numbers in [-1, 1], [pleasure, arousal, dominance], e.g. elated: [0.5, 0.42, 0.23]"
)

# How to write each section's values (the machine's come from cyborg.controller.config).
_FIXES = {
    **MACHINE_FIXES,
    (EmotionSettings,): "write emotion as a mapping of settings, e.g. emotion: {decay_rate: 0.15}",
    (EmotionSettings, "prototypes"): "write prototypes as a mapping name: [pleasure, arousal, dominance], "
    "e.g. {elated: [0.5, 0.42, 0.23]}",
    (EmotionSettings, "prototypes", "*"): _PROTOTYPE_FIX,
    (EmotionSettings, "prototypes", "*", "*"): _PROTOTYPE_FIX,
    (EmotionSettings, "time_decay_half_lives"): "write half-lives as a mapping of seconds, e.g. "
    "{pleasure: 600, arousal: 300}",
    (MotivatorSettings,): "write motivator as a mapping of settings, e.g. motivator: {rate_seconds: 2, "
    "events: []}",
    (MotivatorSettings, "events"): "write events as a list, e.g. events: [{state: idle, event: music_play, "
    "reward_pleasure: 0.1}]",
    (MotivationalEvent,): "write each event as a mapping, e.g. {state: idle, event: music_play, "
    "reward_pleasure: 0.1}",
    (MotivationalEvent, "state"): "name the state in which the motivator may send the event, e.g. "
    "state: idle",
    (MotivationalEvent, "event"): "name a transition of that state, e.g. event: music_play",
    ("modules",): "write modules as a mapping node name: settings, e.g. modules: {cyborg_idle: {kind: idle}}",
    ("navigation",): "write navigation as a mapping, or remove it (no component reads it)",
    ("gatekeepers",): "write gatekeepers as a list, e.g. gatekeepers: [{name: cyborg_speech_gatekeeper, "
    "input: /text_to_speech, output: /cyborg_tts/say, resource: speech}]",
    (GatekeeperModel,): "write each gatekeeper as a mapping with name, input, output and resource",
}


def load_config(path: str | Path) -> LoadedConfig:
    """Read, parse and validate a robot's YAML file; raises ConfigError listing every problem."""
    path = Path(path)
    try:
        text = read_text_file(path)
    except OSError as exc:
        raise ConfigError(
            f"cannot read the file: {exc.strerror}; fix: check the path", source=str(path)
        ) from exc
    return parse_config(text, source=str(path))


def parse_config(text: str, source: str = "<config>") -> LoadedConfig:
    """Parse and validate the text of a robot's YAML file; ``source`` names it in the messages."""
    data = load_yaml(text, source, MACHINE_KEYS)
    if not isinstance(data, dict):
        held = "nothing (it is empty)" if data is None else yaml_kind(data)
        raise ConfigError(
            f"top level: the file holds {held}, but must be a mapping with at least a 'states:' section; "
            "fix: start from the example in docs/configuration.md",
            source=source,
        )
    try:
        model = ConfigModel.model_validate(data)
    except ValidationError as exc:
        problems = describe_errors(
            exc, ConfigModel, name=name_machine_location, fixes=_FIXES, doc="docs/configuration.md"
        )
        raise ConfigError(problems, source=source) from exc
    machine, warnings = build_machine(
        model, source, lambda machine: check_motivational_events(machine, model.motivator), text=text
    )
    return LoadedConfig(machine=machine, model=model, source=source, warnings=warnings, text=text)


def check_motivational_events(machine: MachineSpec, settings: MotivatorSettings) -> list[str]:
    """Every motivational event must be a transition of its state (the motivator sends it there)."""
    problems = []
    for entry in settings.events:
        if entry.state not in machine.states:
            problems.append(
                f"motivator event {entry.event!r}: state {entry.state!r} is not defined"
                f"{suggest(entry.state, sorted(machine.states))}; fix: name a defined state"
            )
        elif entry.event not in machine.transitions_of(entry.state):
            valid = ", ".join(sorted(machine.transitions_of(entry.state))) or "none"
            problems.append(
                f"motivator event {entry.event!r} is no transition of state {entry.state!r}; "
                f"fix: add '{entry.event}: <target>' to its transitions or use one of: {valid}"
            )
    return problems


def packaged_config(name: str) -> Path:
    """Path of a configuration file shipped with the package (``src/cyborg/data``)."""
    return Path(str(resources.files("cyborg") / "data" / name))
