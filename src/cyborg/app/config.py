"""Load and validate the state machine's YAML file.

The schema (pydantic) checks types; the semantic checks here check the
machine: unknown targets, missing ``aborted`` transitions, duplicate states,
superstates without an initial substate. Every problem names the file, where
in it, what is wrong and the fix. Unreachable states are warnings, not errors.
docs/configuration.md describes every key; keep it in step with the models here.

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

import contextlib
import difflib
import enum
import re
from dataclasses import dataclass, field
from pathlib import Path
from types import UnionType
from typing import Any, Union, get_args, get_origin

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator
from pydantic.fields import FieldInfo
from pydantic_core import ErrorDetails, PydanticUndefined

from cyborg.controller.machine import ABORTED, MachineSpec, StateSpec, Timeouts
from cyborg.emotion.model import EmotionSettings
from cyborg.errors import ConfigError
from cyborg.limits import MAX_YAML_BYTES, MAX_YAML_DEPTH, MAX_YAML_NODES
from cyborg.motivator.logic import MotivatorSettings

# --- YAML with duplicate-key detection -------------------------------------------

Loader = yaml.SafeLoader | yaml.CSafeLoader


def load_yaml(text: str, source: str) -> Any:
    """Parse YAML, reporting syntax errors and duplicate keys with line numbers.

    PyYAML silently keeps the last of two equal keys; here every duplicate is an error
    whose advice fits where it is (two states of one name, one event twice in a state's
    transitions, one resource granted twice, a section written twice).
    """
    size = len(text.encode("utf-8", errors="surrogateescape"))
    if size > MAX_YAML_BYTES:
        raise ConfigError(
            f"the file is {size:,} bytes, over the limit of {MAX_YAML_BYTES:,} bytes; fix: check that this is the "
            "right file, and split a long scenario into several scripts",
            source=source,
        )
    if yaml_loader(text) is yaml.CSafeLoader:
        try:
            return _load_yaml_with(yaml.CSafeLoader(text), source)
        except ConfigError as exc:
            if not isinstance(exc.__cause__, yaml.YAMLError):
                raise
            # The C loader's messages have no file name and no excerpt: the Python one tells it better.
    loader = yaml.SafeLoader(text)
    loader.name = source  # syntax errors then say 'in "machine.yaml", line 3'
    return _load_yaml_with(loader, source)


_FLOW_BRACKETS = re.compile(r"[\[\]{}]")
_C_LOADER_DEPTH = 1000
"""libyaml's composer recurses in C: tens of thousands of nested brackets crash the process."""


def yaml_loader(text: str) -> type[Loader]:
    """The fast C loader (libyaml) if it is there and safe for ``text``, else the Python one.

    Brackets inside quotes count too: a file that merely looks deep is read by the Python
    loader, which refuses real depth with a RecursionError instead of crashing.
    """
    if not hasattr(yaml, "CSafeLoader"):
        return yaml.SafeLoader
    depth = 0
    for match in _FLOW_BRACKETS.finditer(text):
        depth += 1 if match.group() in "[{" else -1
        if depth > _C_LOADER_DEPTH:
            return yaml.SafeLoader
    return yaml.CSafeLoader


def _load_yaml_with(loader: Loader, source: str) -> Any:
    try:
        try:
            root = loader.get_single_node()
        except RecursionError:
            raise ConfigError(
                f"the values are nested too deeply (over {MAX_YAML_DEPTH} levels of mappings and lists); "
                "fix: flatten the structure",
                source=source,
            ) from None
        if root is None:
            return None
        _check_shape(root, source)
        duplicates: list[str] = []
        _find_duplicates(loader, root, [], duplicates, set())
        if duplicates:
            raise ConfigError(duplicates, source=source)
        return loader.construct_document(root)
    except yaml.YAMLError as exc:
        raise ConfigError(
            f"not valid YAML: {exc}\nfix: correct the syntax at the line and column shown "
            "(usually the indentation, a missing ':' or space after it, or an unclosed bracket or quote)",
            source=source,
        ) from exc
    finally:
        loader.dispose()  # type: ignore[no-untyped-call]


_MERGE_TAG = "tag:yaml.org,2002:merge"


def _check_shape(root: yaml.Node, source: str) -> None:
    """Refuse a document that expands to too many values, nests too deeply or refers to itself.

    Aliases (``*name``) repeat a node without copying it, so a few hundred bytes can stand for
    billions of values ("billion laughs"); the expanded count is summed over the node graph
    (each node once) before anything is constructed.
    """
    expanded: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[yaml.Node, int, bool]] = [(root, 1, False)]
    while stack:
        node, depth, done = stack.pop()
        key = id(node)
        if done:
            on_path.discard(key)
            total = 1 + sum(expanded[id(child)] for child in _children(node))
            if total > MAX_YAML_NODES:
                raise ConfigError(
                    f"line {node.start_mark.line + 1}: the YAML expands to over {MAX_YAML_NODES:,} values "
                    "(aliases '*name' repeat what they name); fix: write the values out or use fewer "
                    "aliases",
                    source=source,
                )
            expanded[key] = total
            continue
        if key in expanded:
            continue
        if key in on_path:
            raise ConfigError(
                f"line {node.start_mark.line + 1}: an alias refers to the mapping or list that contains it, "
                "which never ends; fix: remove that alias",
                source=source,
            )
        if depth > MAX_YAML_DEPTH:
            raise ConfigError(
                f"line {node.start_mark.line + 1}: the values are nested over {MAX_YAML_DEPTH} levels deep; "
                "fix: flatten the structure",
                source=source,
            )
        on_path.add(key)
        stack.append((node, depth, True))
        stack.extend((child, depth + 1, False) for child in _children(node) if id(child) not in expanded)


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [part for pair in node.value for part in pair]
    return []


def _find_duplicates(
    loader: Loader, node: yaml.Node, path: list[Any], out: list[str], seen_nodes: set[int]
) -> None:
    if id(node) in seen_nodes:  # an alias of a node already checked
        return
    seen_nodes.add(id(node))
    if isinstance(node, yaml.SequenceNode):
        for index, item in enumerate(node.value):
            _find_duplicates(loader, item, [*path, index], out, seen_nodes)
        return
    if not isinstance(node, yaml.MappingNode):
        return
    first_line: dict[Any, int] = {}
    for key_node, value_node in node.value:
        key: Any = key_node.value
        if isinstance(key_node, yaml.ScalarNode) and key_node.tag != _MERGE_TAG:
            key = loader.construct_object(key_node)  # type: ignore[no-untyped-call]
            line = key_node.start_mark.line + 1
            try:
                first = first_line.get(key)
            except TypeError:  # an unhashable key: pydantic reports it later
                first = None
            if not isinstance(key, str) and _mapping_role(path) != "other":
                out.append(
                    f"line {line}: {_describe_location(path)}: YAML reads the key {key_node.value!r} as "
                    f"{_yaml_kind(key)}, not as a name; fix: put it in quotes, e.g. '{key_node.value}':"
                )
            if first is not None:
                what, fix = _duplicate_advice(path, str(key_node.value))
                earlier = "earlier on the same line" if first == line else f"first at line {first}"
                out.append(f"line {line}: {_describe_location(path)}: {what} ({earlier}); fix: {fix}")
            else:
                with contextlib.suppress(TypeError):
                    first_line[key] = line
        _find_duplicates(loader, value_node, [*path, key], out, seen_nodes)


def _mapping_role(path: list[Any]) -> str:
    """What the keys of the mapping at ``path`` name: sections, states, a state's keys, events..."""
    role = "sections"
    for part in path:
        if role == "sections":
            role = "states" if part == "states" else "other"
        elif role == "states":
            role = "state"
        elif role == "state":
            role = {"states": "states", "transitions": "transitions", "resources": "resources"}.get(
                str(part), "other"
            )
        else:
            role = "other"
    return role


def _duplicate_advice(path: list[Any], key: str) -> tuple[str, str]:
    role = _mapping_role(path)
    if role == "transitions":
        return (
            f"duplicate key {key!r}: the event {key!r} is listed twice in this state's transitions",
            "an event leads to exactly one target: keep the entry with the target you want and "
            "delete the other",
        )
    if role == "states":
        return (
            f"duplicate key {key!r}: the state {key!r} is defined twice",
            "give each state a unique name, or merge the two entries into one",
        )
    if role == "resources":
        return (
            f"duplicate key {key!r}: the resource {key!r} is granted twice in this state",
            "a resource belongs to one node at a time: keep the entry naming the node you want",
        )
    if role == "state":
        return (
            f"duplicate key {key!r}: this state sets {key!r} twice",
            f"write '{key}:' once (merge the two entries if both are mappings)",
        )
    if role == "sections":
        return (
            f"duplicate key {key!r}: the section {key!r} appears twice",
            "merge the two sections into one",
        )
    return f"duplicate key {key!r}", "keep one of the two entries (merge them if both are mappings)"


# --- schema ------------------------------------------------------------------------


class StateModel(BaseModel):
    model_config = ConfigDict(extra="forbid")

    action: str | None = Field(None, description="action server of the module that serves this state")
    description: str = Field("", description="free text for the reader; the controller ignores it")
    transitions: dict[str, str] = Field(default_factory=dict, description="event: target state")
    resources: dict[str, str] = Field(default_factory=dict, description="resource: node that may use it")
    initial: str | None = Field(None, description="substate entered first (default: the first listed)")
    states: dict[str, StateModel] | None = Field(None, description="substates of this superstate")

    @field_validator("action")
    @classmethod
    def _action_not_blank(cls, value: str | None) -> str | None:
        if value is not None and not value.strip("/ "):
            raise ValueError("action is empty: name the module's action server, e.g. cyborg_idle/idle")
        return value


class TimeoutsModel(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

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

    initial: str = Field("idle", description="state the controller enters at start")
    timeouts: TimeoutsModel = Field(default_factory=TimeoutsModel)  # type: ignore[arg-type]
    states: dict[str, StateModel] = Field(description="the states: name: state")
    emotion: EmotionSettings = Field(default_factory=EmotionSettings)  # type: ignore[arg-type]
    motivator: MotivatorSettings = Field(default_factory=MotivatorSettings)  # type: ignore[arg-type]
    navigation: dict[str, Any] = Field(
        default_factory=dict, description="reserved; not read by any component"
    )
    modules: dict[str, Any] = Field(
        default_factory=dict, description="node name: module settings (kind: ...)"
    )
    gatekeepers: list[GatekeeperModel] = Field(default_factory=list)


@dataclass
class LoadedConfig:
    """A validated configuration: the machine, the raw model and any warnings."""

    machine: MachineSpec
    model: ConfigModel
    source: str
    warnings: list[str] = field(default_factory=list)


# --- loading ------------------------------------------------------------------------


# How to write a value whose type is wrong, by where it is. ``*`` stands for any name or index;
# ``state:`` paths are inside a state (at any depth), the others start at the top of the file.
_TYPE_FIXES: dict[tuple[str, ...], str] = {
    ("state:",): "write each state as a mapping, e.g. idle: {action: cyborg_idle/idle, transitions: "
    "{aborted: idle}}",
    ("state:", "transitions"): "write transitions as a mapping event: target, e.g. {succeeded: idle, "
    "aborted: idle}",
    ("state:", "transitions", "*"): "the target of an event is the name of a state, e.g. succeeded: idle",
    ("state:", "resources"): "write resources as a mapping resource: node, e.g. {speech: cyborg_joke}",
    ("state:", "resources", "*"): "a resource is given to a node by its name, e.g. speech: cyborg_joke",
    ("state:", "action"): "name the module's action server, e.g. action: cyborg_idle/idle",
    ("state:", "description"): "write the description as text; put it in quotes if it contains ': '",
    ("state:", "initial"): "name one of the substates, e.g. initial: navigation_planning",
    ("state:", "states"): "write substates as a mapping name: state, e.g. states: {planning: "
    "{action: cyborg_navigation/planning}}",
    ("states",): "write states as a mapping name: state, e.g. states: {idle: {action: cyborg_idle/idle, "
    "transitions: {aborted: idle}}}",
    ("initial",): "name the state the controller starts in, e.g. initial: idle",
    ("timeouts",): "write timeouts as a mapping, e.g. timeouts: {connect: 2.0, preempt: 2.0}",
    ("emotion",): "write emotion as a mapping of settings, e.g. emotion: {decay_rate: 0.15}",
    ("emotion", "prototypes"): "write prototypes as a mapping name: [pleasure, arousal, dominance], "
    "e.g. {elated: [0.5, 0.42, 0.23]}",
    ("emotion", "prototypes", "*"): "give three numbers in [-1, 1], [pleasure, arousal, dominance], "
    "e.g. elated: [0.5, 0.42, 0.23]",
    ("emotion", "prototypes", "*", "*"): "give three numbers in [-1, 1], [pleasure, arousal, dominance], "
    "e.g. elated: [0.5, 0.42, 0.23]",
    ("emotion", "time_decay_half_lives"): "write half-lives as a mapping of seconds, e.g. "
    "{pleasure: 600, arousal: 300}",
    ("motivator",): "write motivator as a mapping of settings, e.g. motivator: {rate_seconds: 2, events: []}",
    ("motivator", "events"): "write events as a list, e.g. events: [{state: idle, event: music_play, "
    "reward_pleasure: 0.1}]",
    ("motivator", "events", "*"): "write each event as a mapping, e.g. {state: idle, event: music_play, "
    "reward_pleasure: 0.1}",
    ("modules",): "write modules as a mapping node name: settings, e.g. modules: {cyborg_idle: {kind: idle}}",
    ("navigation",): "write navigation as a mapping, or remove it (no component reads it)",
    ("gatekeepers",): "write gatekeepers as a list, e.g. gatekeepers: [{name: cyborg_speech_gatekeeper, "
    "input: /text_to_speech, output: /cyborg_tts/say, resource: speech}]",
    ("gatekeepers", "*"): "write each gatekeeper as a mapping with name, input, output and resource",
}

_MISSING_FIXES: dict[tuple[str, ...], str] = {
    ("motivator", "events", "*", "state"): "add 'state: <the state in which the motivator may send the "
    "event>', e.g. state: idle",
    (
        "motivator",
        "events",
        "*",
        "event",
    ): "add 'event: <a transition of that state>', e.g. event: music_play",
}

_WRONG_TYPE = {
    "dict_type": "must be a mapping (key: value)",
    "model_type": "must be a mapping (key: value)",
    "model_attributes_type": "must be a mapping (key: value)",
    "list_type": "must be a list",
    "tuple_type": "must be a list",
    "string_type": "must be text",
    "float_type": "must be a number",
    "float_parsing": "must be a number",
    "int_type": "must be a whole number",
    "int_parsing": "must be a whole number",
    "int_from_float": "must be a whole number",
    "finite_number": "must be a finite number",
    "bool_type": "must be true or false",
    "bool_parsing": "must be true or false",
}


def _yaml_kind(value: Any) -> str:
    """How a YAML user would call the type of ``value``."""
    if value is None:
        return "an empty value"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, int | float):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the text {_short(value)}"
    if isinstance(value, list):
        return f"a list {_short(value)}"
    if isinstance(value, dict):
        return f"a mapping {_short(value)}"
    return _short(value)


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _pattern(loc: list[Any]) -> tuple[str, ...]:
    """``loc`` with names folded: ('states', 'a', 'states', 'b', 'transitions', 'go') -> ('state:', 'transitions', '*')."""
    i = 0
    while i + 1 < len(loc) and loc[i] == "states":
        i += 2
    rest = _star([str(p) for p in loc[i:]])
    return ("state:", *rest) if i else rest


def _star(parts: list[str]) -> tuple[str, ...]:
    """Replace names and indexes (the parts after a container key) by ``*``."""
    out: list[str] = []
    for part in parts:
        container = out[-1] if out else ""
        if container in ("transitions", "resources", "prototypes", "events", "gatekeepers", "modules") or (
            container == "*" and len(out) >= 2 and out[-2] == "prototypes"
        ):
            out.append("*")
        else:
            out.append(part)
    return tuple(out)


def _annotation_at(loc: list[Any]) -> Any:
    """The declared type of the value at ``loc`` in :class:`ConfigModel`, or None if unknown."""
    annotation: Any = ConfigModel
    for part in loc:
        args = [a for a in get_args(annotation) if a is not type(None)]
        if get_origin(annotation) in (Union, UnionType) and len(args) == 1:
            annotation = args[0]
        origin = get_origin(annotation)
        if isinstance(annotation, type) and issubclass(annotation, BaseModel):
            info = annotation.model_fields.get(str(part))
            if info is None:
                return None
            annotation = info.annotation
        elif origin is dict:
            annotation = get_args(annotation)[1]
        elif origin in (list, tuple):
            annotation = get_args(annotation)[0]
        else:
            return None
    return annotation


def _field(loc: list[Any]) -> FieldInfo | None:
    parent = _annotation_at(loc[:-1]) if loc else None
    if isinstance(parent, type) and issubclass(parent, BaseModel):
        return parent.model_fields.get(str(loc[-1]))
    return None


def _example(loc: list[Any], info: FieldInfo | None) -> str:
    """', e.g. connect: 2.0' from the field's default, or nothing."""
    if info is None or info.default is PydanticUndefined or info.default is None:
        return ""
    default = info.default.value if isinstance(info.default, enum.Enum) else info.default
    return f", e.g. {loc[-1]}: {default}"


def _describe_error(error: ErrorDetails) -> str:
    """One problem as 'where: what is wrong; fix: how', for a pydantic error."""
    loc = list(error["loc"])
    kind = error["type"]
    value = error.get("input")
    if loc and loc[-1] == "[key]":  # the key of a mapping entry, not its value
        key = loc[-2]
        where = _describe_location(loc[:-2])
        return (
            f"{where}: the key {key!r} is not text; fix: put the name in quotes so YAML reads it as text "
            "(unquoted numbers, yes, no, on, off, true, false, null and ~ are not names)"
        )
    where = _describe_location(loc)
    info = _field(loc)
    description = f" ({info.description})" if info is not None and info.description else ""
    if kind == "extra_forbidden":
        parent = _annotation_at(loc[:-1])
        allowed = (
            sorted(parent.model_fields) if isinstance(parent, type) and issubclass(parent, BaseModel) else []
        )
        hint = _suggest(str(loc[-1]), allowed)
        where = _describe_location(loc[:-1])
        known = f"; the keys here are: {', '.join(allowed)}" if allowed else ""
        return f"{where}: unknown key {loc[-1]!r}{hint}; fix: remove it or correct its spelling{known}"
    if kind == "missing":
        if loc == ["states"]:
            return (
                "top level: missing required key 'states'; fix: add the states, e.g. "
                "states: {idle: {action: cyborg_idle/idle, transitions: {aborted: idle}}}"
            )
        where = _describe_location(loc[:-1])
        if _pattern(loc[:-1])[:2] == ("emotion", "prototypes"):
            return f"{where}: has too few numbers; fix: {_TYPE_FIXES[('emotion', 'prototypes', '*')]}"
        fix = _MISSING_FIXES.get(_pattern(loc), f"add '{loc[-1]}: ...'{description}")
        return f"{where}: missing required key {loc[-1]!r}; fix: {fix}"
    if kind == "value_error":  # our own validators: 'what is wrong: how to fix it'
        text = error["msg"].removeprefix("Value error, ")
        what, _, fix = text.partition(": ")
        return f"{where}: {what}; fix: {fix or 'see docs/configuration.md'}"
    pattern = _pattern(loc)
    if kind in _WRONG_TYPE:
        known_fix = _TYPE_FIXES.get(pattern)
        if known_fix is not None:
            fix = known_fix
        else:
            fix = (
                f"write it as {_WRONG_TYPE[kind].removeprefix('must be ')}{_example(loc, info)}{description}"
            )
        return f"{where}: {_WRONG_TYPE[kind]}, not {_yaml_kind(value)}; fix: {fix}"
    if kind == "too_long" and pattern[:2] == ("emotion", "prototypes"):
        return f"{where}: has too many numbers; fix: {_TYPE_FIXES[('emotion', 'prototypes', '*')]}"
    ctx = error.get("ctx", {})
    limits = {
        "greater_than": f"use a number greater than {ctx.get('gt')}",
        "greater_than_equal": f"use a number of at least {ctx.get('ge')}",
        "less_than": f"use a number less than {ctx.get('lt')}",
        "less_than_equal": f"use a number of at most {ctx.get('le')}",
        "string_too_short": "write a name; it must not be empty",
        "too_short": f"list at least {ctx.get('min_length')} entries",
        "enum": f"use one of {ctx.get('expected')}",
        "literal_error": f"use one of {ctx.get('expected')}",
    }
    fix = limits.get(kind, "see docs/configuration.md for what this key accepts")
    what = error["msg"].replace("Input should be", "must be").replace("String should", "must")
    return f"{where}: {what}, not {_yaml_kind(value)}; fix: {fix}{description}"


def _format_pydantic(exc: ValidationError) -> list[str]:
    return [_describe_error(error) for error in exc.errors()]


def _describe_location(loc: list[Any]) -> str:
    parts: list[str] = []
    i = 0
    while i < len(loc):
        if loc[i] == "states" and i + 1 < len(loc):
            parts.append(f"state {loc[i + 1]!r}")
            i += 2
        elif isinstance(loc[i], int):
            parts.append(f"entry {loc[i] + 1}")
            i += 1
        else:
            parts.append(str(loc[i]))
            i += 1
    return " > ".join(parts) if parts else "top level"


def load_config(path: str | Path) -> LoadedConfig:
    """Read, parse and validate a state machine file; raises ConfigError listing every problem."""
    path = Path(path)
    try:
        text = read_text_file(path)
    except OSError as exc:
        raise ConfigError(
            f"cannot read the file: {exc.strerror}; fix: check the path", source=str(path)
        ) from exc
    return parse_config(text, source=str(path))


def read_text_file(path: Path) -> str:
    """The UTF-8 text of a YAML file; ConfigError if it is too large or not UTF-8 (OSError passes)."""
    with path.open("rb") as handle:
        data = handle.read(MAX_YAML_BYTES + 1)
    if len(data) > MAX_YAML_BYTES:
        raise ConfigError(
            f"the file is over the limit of {MAX_YAML_BYTES:,} bytes; fix: check that this is the right file, "
            "and split a long scenario into several scripts",
            source=str(path),
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise ConfigError(
            f"line {line}: the file is not UTF-8 text (byte {data[exc.start]:#04x} at offset {exc.start}); "
            "fix: save it as UTF-8 in your editor (e.g. `iconv -f latin1 -t utf-8`)",
            source=str(path),
        ) from None


def parse_config(text: str, source: str = "<config>") -> LoadedConfig:
    data = load_yaml(text, source)
    if not isinstance(data, dict):
        held = "nothing (it is empty)" if data is None else _yaml_kind(data)
        raise ConfigError(
            f"top level: the file holds {held}, but must be a mapping with at least a 'states:' section; "
            "fix: start from the example in docs/configuration.md",
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
            first = out[name].parent
            places = [f"inside {p!r}" if p else "at the top level" for p in (first, parent)]
            problems.append(
                f"state {name!r}: defined twice, {places[0]} and {places[1]}; "
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
        if initial is not None and not children:
            problems.append(
                f"state {name!r}: sets initial {initial!r} but has no substates; fix: remove 'initial:' "
                "(only a superstate, one with 'states:', has an initial substate)"
            )
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
    if not model.states:
        raise ConfigError(
            "states: is empty; fix: define at least one state, e.g. "
            "states: {idle: {action: cyborg_idle/idle, transitions: {aborted: idle}}}",
            source=source,
        )
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
