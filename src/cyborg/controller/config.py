"""Load and validate the state machine's YAML file.

The schema (pydantic) checks types; the semantic checks here check the
machine: unknown targets, missing ``aborted`` transitions, duplicate states,
superstates without an initial substate. Every problem names the file, the
state and the fix. Unreachable states are warnings, not errors.

File layout::

    initial: idle
    timeouts: {connect: 2.0, preempt: 2.0}
    states:
      idle:
        action: cyborg_idle/idle
        transitions: {music_play: music, aborted: idle}
      navigation:                 # a superstate: its transitions apply to all substates
        initial: navigation_planning
        transitions: {aborted: idle}
        resources: {base: cyborg_navigation}
        states:
          navigation_planning: {action: cyborg_navigation/planning, transitions: {...}}
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from cyborg.controller.machine import ABORTED, MachineSpec, StateSpec, Timeouts
from cyborg.emotion.model import EmotionSettings
from cyborg.errors import ConfigError
from cyborg.motivator.logic import MotivatorSettings

# --- YAML with duplicate-key detection -------------------------------------------


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate keys instead of silently keeping the last."""

    duplicates: list[str]


def _construct_mapping(loader: _StrictLoader, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
    seen: dict[Any, int] = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)  # type: ignore[no-untyped-call]
        line = key_node.start_mark.line + 1
        if key in seen:
            loader.duplicates.append(
                f"line {line}: duplicate key {key!r} (first at line {seen[key]}); "
                "fix: give each state a unique name or merge the two entries"
            )
        else:
            seen[key] = line
    return loader.construct_mapping(node, deep=deep)  # type: ignore[no-untyped-call]


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)  # type: ignore[arg-type]


def load_yaml(text: str, source: str) -> Any:
    """Parse YAML, reporting syntax errors and duplicate keys with line numbers."""
    loader = _StrictLoader(text)
    loader.duplicates = []
    try:
        data = loader.get_single_data()  # type: ignore[no-untyped-call]
    except yaml.YAMLError as exc:
        raise ConfigError(f"not valid YAML: {exc}", source=source) from exc
    finally:
        loader.dispose()  # type: ignore[no-untyped-call]
    if loader.duplicates:
        raise ConfigError(loader.duplicates, source=source)
    return data


# --- schema ------------------------------------------------------------------------


class StateModel(BaseModel):
    model_config = ConfigDict(extra="forbid")

    action: str | None = Field(None, description="action server of the module that serves this state")
    description: str = ""
    transitions: dict[str, str] = Field(default_factory=dict)
    resources: dict[str, str] = Field(default_factory=dict)
    initial: str | None = None
    states: dict[str, StateModel] | None = None

    @field_validator("action")
    @classmethod
    def _action_not_blank(cls, value: str | None) -> str | None:
        if value is not None and not value.strip("/ "):
            raise ValueError("action is empty: name the module's action server, e.g. cyborg_idle/idle")
        return value


class TimeoutsModel(BaseModel):
    model_config = ConfigDict(extra="forbid")

    connect: float = Field(2.0, gt=0, description="seconds to wait for a module's action server")
    preempt: float = Field(2.0, gt=0, description="seconds to wait for a module to acknowledge a cancel")


class GatekeeperModel(BaseModel):
    """A relay in front of an output module: only the node holding ``resource`` gets through."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(min_length=1, description="node name of the gatekeeper")
    input: str = Field(min_length=1, description="topic the behaviour modules publish on")
    output: str = Field(min_length=1, description="topic the output module listens to")
    resource: str = Field(min_length=1, description="resource name in the states' resource lists")


class ConfigModel(BaseModel):
    """The whole YAML file. Sections other than the state machine belong to their components."""

    model_config = ConfigDict(extra="forbid")

    initial: str = "idle"
    timeouts: TimeoutsModel = Field(default_factory=TimeoutsModel)  # type: ignore[arg-type]
    states: dict[str, StateModel]
    emotion: EmotionSettings = Field(default_factory=EmotionSettings)  # type: ignore[arg-type]
    motivator: MotivatorSettings = Field(default_factory=MotivatorSettings)  # type: ignore[arg-type]
    navigation: dict[str, Any] = Field(default_factory=dict)
    modules: dict[str, Any] = Field(default_factory=dict)
    gatekeepers: list[GatekeeperModel] = Field(default_factory=list)


@dataclass
class LoadedConfig:
    """A validated configuration: the machine, the raw model and any warnings."""

    machine: MachineSpec
    model: ConfigModel
    source: str
    warnings: list[str] = field(default_factory=list)


# --- loading ------------------------------------------------------------------------


def _format_pydantic(exc: ValidationError) -> list[str]:
    problems = []
    for error in exc.errors():
        loc = list(error["loc"])
        where = _describe_location(loc)
        message = error["msg"]
        if error["type"] == "extra_forbidden":
            message = f"unknown key {loc[-1]!r}; fix: remove it or check its spelling"
        elif error["type"] == "missing":
            message = f"missing required key {loc[-1]!r}; fix: add it"
        problems.append(f"{where}: {message}")
    return problems


def _describe_location(loc: list[Any]) -> str:
    parts: list[str] = []
    i = 0
    while i < len(loc):
        if loc[i] == "states" and i + 1 < len(loc):
            parts.append(f"state {loc[i + 1]!r}")
            i += 2
        else:
            parts.append(str(loc[i]))
            i += 1
    return " > ".join(parts) if parts else "top level"


def load_config(path: str | Path) -> LoadedConfig:
    """Read, parse and validate a state machine file; raises ConfigError listing every problem."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(
            f"cannot read the file: {exc.strerror}; fix: check the path", source=str(path)
        ) from exc
    return parse_config(text, source=str(path))


def parse_config(text: str, source: str = "<config>") -> LoadedConfig:
    data = load_yaml(text, source)
    if not isinstance(data, dict):
        raise ConfigError(
            "the file must be a mapping with at least a 'states' key; fix: see docs/configuration.md",
            source=source,
        )
    try:
        model = ConfigModel.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(_format_pydantic(exc), source=source) from exc
    machine, warnings = build_machine(model, source)
    return LoadedConfig(machine=machine, model=model, source=source, warnings=warnings)


def _flatten(
    states: dict[str, StateModel],
    parent: str | None,
    out: dict[str, StateSpec],
    problems: list[str],
) -> None:
    for name, model in states.items():
        if name in out:
            problems.append(
                f"state {name!r}: defined twice (also inside {out[name].parent or 'the top level'}); "
                "fix: state names must be unique across all levels, rename one"
            )
            continue
        children = tuple(model.states or ())
        if model.action is not None and children:
            problems.append(
                f"state {name!r}: has both an action and substates; fix: a state is either served "
                "by a module (action) or groups substates (states), move the action into a substate"
            )
        if model.action is None and not children:
            problems.append(
                f"state {name!r}: has no action; fix: add 'action: <module>/<server>' naming the "
                "module's action server"
            )
        initial = model.initial
        if children and initial is None:
            initial = children[0]
        out[name] = StateSpec(
            name=name,
            action=model.action.strip() if model.action else None,
            transitions=dict(model.transitions),
            resources=dict(model.resources),
            parent=parent,
            initial=initial if children else None,
            children=children,
            description=model.description,
        )
        if model.states:
            _flatten(model.states, name, out, problems)


def _suggest(name: str, choices: list[str]) -> str:
    close = difflib.get_close_matches(name, choices, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def build_machine(model: ConfigModel, source: str) -> tuple[MachineSpec, list[str]]:
    """Turn the schema model into a MachineSpec, checking the machine's semantics."""
    problems: list[str] = []
    states: dict[str, StateSpec] = {}
    _flatten(model.states, None, states, problems)
    names = sorted(states)
    for state in states.values():
        for event, target in state.transitions.items():
            if target not in states:
                problems.append(
                    f"state {state.name!r}: transition {event!r} leads to unknown state {target!r}"
                    f"{_suggest(target, names)}; fix: use one of {', '.join(names)}"
                )
        if state.children and state.initial not in state.children:
            problems.append(
                f"state {state.name!r}: initial substate {state.initial!r} is not one of its substates "
                f"({', '.join(state.children)}); fix: name one of them"
            )
    if model.initial not in states:
        problems.append(
            f"initial state {model.initial!r} is not defined{_suggest(model.initial, names)}; "
            f"fix: define it or set 'initial:' to one of {', '.join(names)}"
        )
    if problems:
        raise ConfigError(problems, source=source)
    machine = MachineSpec(
        states=states,
        initial=model.initial,
        timeouts=Timeouts(connect=model.timeouts.connect, preempt=model.timeouts.preempt),
    )
    for leaf in machine.leaves():
        if machine.lookup(leaf.name, ABORTED) is None:
            problems.append(
                f"state {leaf.name!r}: no 'aborted' transition (needed when its module fails or "
                "cannot be reached); fix: add 'aborted: idle' to its transitions or to a superstate's"
            )
    problems.extend(check_motivational_events(machine, model.motivator))
    if problems:
        raise ConfigError(problems, source=source)
    reachable = machine.reachable()
    warnings = [
        f"{source}: state {name!r} is unreachable from {model.initial!r}: no transition leads to it"
        for name in names
        if name not in reachable
    ]
    return machine, warnings


def check_motivational_events(machine: MachineSpec, settings: MotivatorSettings) -> list[str]:
    """Every motivational event must be a transition of its state (the motivator sends it there)."""
    problems = []
    for entry in settings.events:
        if entry.state not in machine.states:
            problems.append(
                f"motivator event {entry.event!r}: state {entry.state!r} is not defined"
                f"{_suggest(entry.state, sorted(machine.states))}; fix: name a defined state"
            )
        elif entry.event not in machine.transitions_of(entry.state):
            valid = ", ".join(sorted(machine.transitions_of(entry.state))) or "none"
            problems.append(
                f"motivator event {entry.event!r} is no transition of state {entry.state!r}; "
                f"fix: add '{entry.event}: <target>' to its transitions or use one of: {valid}"
            )
    return problems
