"""The state machine's part of the robot's YAML: its schema, its messages and its checks.

The schema (pydantic) checks types; :func:`build_machine` checks the machine: unknown
targets, missing ``aborted`` transitions, duplicate states, superstates without an initial
substate. Every problem names where in the file, what is wrong and the fix; unreachable
states are warnings, not errors. The whole robot's file (emotion, motivator, modules...)
extends :class:`MachineModel` in :mod:`cyborg.app.config`. docs/configuration.md describes
every key; keep it in step with the models here.

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

import unicodedata
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

from pydantic import BaseModel, ConfigDict, Field, field_validator

from cyborg.configfile import Fixes, KeyRules, Location, key_lines, name_location, suggest
from cyborg.controller.clashes import explore
from cyborg.controller.machine import ABORTED, MachineSpec, ResourcePolicy, StateSpec, Timeouts
from cyborg.errors import ConfigError, InvalidValueError

# --- schema ------------------------------------------------------------------------


class StateModel(BaseModel):
    model_config = ConfigDict(extra="forbid")

    action: str | None = Field(None, description="action server of the module that serves this state")
    description: str = Field("", description="free text for the reader; the controller ignores it")
    transitions: dict[str, str] = Field(default_factory=dict, description="event: target state")
    resources: dict[str, str] = Field(default_factory=dict, description="resource: node that may use it")
    initial: str | None = Field(None, description="substate entered first (default: the first listed)")
    states: dict[str, StateModel] | None = Field(None, description="substates of this superstate")
    parallel: bool = Field(
        False, description="a superstate whose substates (regions) all run at once, each with a priority"
    )
    priority: int | None = Field(
        None, description="a region's rank in its parallel state: the higher wins an arbitrated resource"
    )

    @field_validator("action")
    @classmethod
    def _action_not_blank(cls, value: str | None) -> str | None:
        if value is not None and not value.strip("/ "):
            raise InvalidValueError("action is empty: name the module's action server, e.g. cyborg_idle/idle")
        return value


MIN_TIMEOUT = 0.1
MAX_TIMEOUT = 3600.0
"""Seconds: the range of every timeout of the machine."""

_BIDI_CONTROLS = frozenset("\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


def name_problem(name: str) -> str | None:
    """Why a state or event name cannot be used (blank, or a control character), or None."""
    if not name.strip():
        return "is blank, so it can never be sent or shown"
    for char in name:
        if unicodedata.category(char) == "Cc" or char in _BIDI_CONTROLS:
            return (
                f"contains the control character U+{ord(char):04X}, which breaks drawing and logs, "
                "or shows another name than the robot uses"
            )
    return None


class TimeoutsModel(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    # Bounded both ways: a connect timeout is also the pace of retries (1e-9 retried 64,000 times a
    # second), and 1e300 waits for ever for a module that is not there.
    connect: float = Field(
        2.0, ge=MIN_TIMEOUT, le=MAX_TIMEOUT, description="seconds to wait for a module's action server"
    )
    preempt: float = Field(
        2.0,
        ge=MIN_TIMEOUT,
        le=MAX_TIMEOUT,
        description="seconds to wait for a module to acknowledge a cancel",
    )
    event_age: float = Field(
        10.0,
        ge=MIN_TIMEOUT,
        le=MAX_TIMEOUT,
        description="seconds an event may wait for the controller; an older one is dropped as stale",
    )


class MachineModel(BaseModel):
    """The state machine's keys of the file; the robot's file adds its components' sections."""

    model_config = ConfigDict(extra="forbid")

    initial: str = Field("idle", description="state the controller enters at start")
    timeouts: TimeoutsModel = Field(default_factory=TimeoutsModel)  # type: ignore[arg-type]
    states: dict[str, StateModel] = Field(description="the states: name: state")
    resource_policy: dict[str, ResourcePolicy] = Field(
        default_factory=dict,
        description="per resource, what two parallel regions holding it means: exclusive (the default: "
        "refused by validation) or arbitrated (the higher-priority region wins, the other is muted)",
    )


# --- messages -----------------------------------------------------------------------

name_machine_location: Callable[[Location], str] = partial(name_location, labels={"states": "state"})
"""('states', 'idle', 'transitions') -> "state 'idle' > transitions"."""

MACHINE_FIXES: Fixes = {
    (StateModel,): "write each state as a mapping, e.g. idle: {action: cyborg_idle/idle, transitions: "
    "{aborted: idle}}",
    (StateModel, "transitions"): "write transitions as a mapping event: target, e.g. {succeeded: idle, "
    "aborted: idle}",
    (StateModel, "transitions", "*"): "the target of an event is the name of a state, e.g. succeeded: idle",
    (StateModel, "resources"): "write resources as a mapping resource: node, e.g. {speech: cyborg_joke}",
    (StateModel, "resources", "*"): "a resource is given to a node by its name, e.g. speech: cyborg_joke",
    (StateModel, "action"): "name the module's action server, e.g. action: cyborg_idle/idle",
    (StateModel, "description"): "write the description as text; put it in quotes if it contains ': '",
    (StateModel, "initial"): "name one of the substates, e.g. initial: navigation_planning",
    (StateModel, "states"): "write substates as a mapping name: state, e.g. states: {planning: "
    "{action: cyborg_navigation/planning}}",
    ("states",): "write states as a mapping name: state, e.g. states: {idle: {action: cyborg_idle/idle, "
    "transitions: {aborted: idle}}}",
    ("initial",): "name the state the controller starts in, e.g. initial: idle",
    (StateModel, "parallel"): "write parallel: true on a superstate whose substates all run at once",
    (StateModel, "priority"): "give each region of a parallel state a whole number, e.g. priority: 10 "
    "(the higher wins an arbitrated resource)",
    ("resource_policy",): "write resource_policy as a mapping resource: policy, e.g. resource_policy: "
    "{speaker: arbitrated}",
    ("resource_policy", "*"): "a resource's policy is exclusive or arbitrated, e.g. speaker: arbitrated",
    ("timeouts",): "write timeouts as a mapping, e.g. timeouts: {connect: 2.0, preempt: 2.0}",
}
"""How to write each part of the machine, for values of the wrong type (see describe_errors)."""


def _mapping_role(path: Location) -> str:
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


def _duplicate_advice(path: Location, key: str) -> tuple[str, str]:
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


MACHINE_KEYS = KeyRules(
    name=name_machine_location,
    duplicate=_duplicate_advice,
    names=lambda path: _mapping_role(path) != "other",
)
"""Duplicate-key advice for the robot's YAML (a state twice, an event twice in a state...)."""


MAX_CLASHES_SHOWN = 20
"""Exclusive-resource clashes listed one by one (the shortest traces first); the rest are counted."""

# --- the machine ----------------------------------------------------------------------


def build_machine(
    model: MachineModel,
    source: str,
    check: Callable[[MachineSpec], list[str]] | None = None,
    *,
    text: str = "",
) -> tuple[MachineSpec, list[str]]:
    """Turn the schema model into a MachineSpec, checking the machine's semantics.

    ``check`` adds the problems other sections find with the machine (the motivator's events);
    they are reported with the machine's own. ``text``: the file's text, so that each problem
    and warning starts with the line of the part it is about. Returns the machine and the warnings.
    """
    lines = key_lines(text) if text else {}
    problems: list[str] = []
    if not model.states:
        raise ConfigError(
            "states: is empty; fix: define at least one state, e.g. "
            "states: {idle: {action: cyborg_idle/idle, transitions: {aborted: idle}}}",
            source=source,
        )
    states: dict[str, StateSpec] = {}
    _flatten(model.states, None, states, problems, _Lines(lines, ()))
    problems.extend(_region_problems(states, _Lines(lines, ()).of_state))
    names = sorted(states)
    where = _Lines(lines, ()).of_state
    problems.extend(_name_problems(states, where))
    for state in states.values():
        for event, target in state.transitions.items():
            if target not in states:
                problems.append(
                    f"{where(states, state.name, 'transitions', event)}state {state.name!r}: transition "
                    f"{event!r} leads to unknown state {target!r}{suggest(target, names)}; "
                    f"fix: use one of {', '.join(names)}"
                )
        if state.children and state.initial not in state.children:
            problems.append(
                f"{where(states, state.name, 'initial')}state {state.name!r}: initial substate "
                f"{state.initial!r} is not one of its substates ({', '.join(state.children)}); "
                "fix: name one of them"
            )
    if model.initial not in states:
        problems.append(
            f"{_Lines(lines, ()).at('initial')}initial state {model.initial!r} is not defined"
            f"{suggest(model.initial, names)}; fix: define it or set 'initial:' to one of {', '.join(names)}"
        )
    if problems:
        raise ConfigError(problems, source=source)
    machine = MachineSpec(
        states=states,
        initial=model.initial,
        timeouts=Timeouts(
            connect=model.timeouts.connect,
            preempt=model.timeouts.preempt,
            event_age=model.timeouts.event_age,
        ),
        resource_policy=dict(model.resource_policy),
    )
    for leaf in machine.leaves():
        if machine.lookup(leaf.name, ABORTED) is None:
            problems.append(
                f"{where(states, leaf.name)}state {leaf.name!r}: no 'aborted' transition (needed when its module fails or "
                "cannot be reached); fix: add 'aborted: idle' to its transitions or to a superstate's"
            )
    if check is not None:
        problems.extend(check(machine))
    if problems:
        raise ConfigError(problems, source=source)
    clashes = explore(machine).clashes if any(state.parallel for state in states.values()) else ()
    if clashes:
        shown = [
            f"{where(states, clash.parallel)}{clash.describe()}" for clash in clashes[:MAX_CLASHES_SHOWN]
        ]
        if len(clashes) > MAX_CLASHES_SHOWN:
            shown.append(
                f"... and {len(clashes) - MAX_CLASHES_SHOWN} more pairs of states clash on exclusive "
                f"resources ({', '.join(sorted({c.resource for c in clashes}))}); fix: as above"
            )
        raise ConfigError(shown, source=source)
    reachable = machine.reachable()
    warnings = [
        f"{source}: {where(states, name)}state {name!r} is unreachable from {model.initial!r}: "
        "no transition leads to it"
        for name in names
        if name not in reachable
    ]
    held = {resource for state in states.values() for resource in state.resources}
    warnings.extend(
        f"{source}: {_Lines(lines, ()).at('resource_policy', resource)}resource_policy names "
        f"{resource!r}, which no state grants{suggest(resource, sorted(held))}; fix: correct its spelling "
        "or remove it"
        for resource in model.resource_policy
        if resource not in held
    )
    return machine, warnings


def _name_problems(states: dict[str, StateSpec], where: Callable[..., str]) -> list[str]:
    fix = "fix: use letters, digits and underscores, e.g. music_play"
    problems = [
        f"{where(states, state.name)}state {state.name!r} {why}; {fix}"
        for state in states.values()
        if (why := name_problem(state.name)) is not None
    ]
    problems.extend(
        f"{where(states, state.name, 'transitions', event)}state {state.name!r}: event {event!r} {why}; {fix}"
        for state in states.values()
        for event in state.transitions
        if (why := name_problem(event)) is not None
    )
    return problems


def _region_problems(states: dict[str, StateSpec], where: Callable[..., str]) -> list[str]:
    """Parallel states: distinct priorities, and no transition from one region into another."""
    problems: list[str] = []
    for parallel in (s for s in states.values() if s.parallel):
        by_priority: dict[int, str] = {}
        for region in parallel.children:
            priority = states[region].priority
            if priority in by_priority:
                problems.append(
                    f"{where(states, region, 'priority')}state {region!r}: has the same priority "
                    f"({priority}) as region {by_priority[priority]!r} of parallel state {parallel.name!r}; "
                    "fix: give every region its own priority (the higher wins an arbitrated resource)"
                )
            by_priority.setdefault(priority, region)
        for region in parallel.children:
            for name in _under(states, region):
                for event, target in states[name].transitions.items():
                    other = _region_holding(states, parallel, target)
                    if other is not None and other != region:
                        problems.append(
                            f"{where(states, name, 'transitions', event)}state {name!r}: transition "
                            f"{event!r} leads from region {region!r} into region {other!r} of parallel "
                            f"state {parallel.name!r}; fix: regions move on their own: target a state of "
                            f"region {region!r}, or one outside {parallel.name!r} to leave it"
                        )
    return problems


def _under(states: dict[str, StateSpec], name: str) -> list[str]:
    return [name, *(inner for child in states[name].children for inner in _under(states, child))]


def _region_holding(states: dict[str, StateSpec], parallel: StateSpec, target: str) -> str | None:
    """The region of ``parallel`` that ``target`` is in, if any."""
    current: str | None = target
    while current is not None and current in states:
        if states[current].parent == parallel.name:
            return current
        current = states[current].parent
    return None


@dataclass(frozen=True)
class _Lines:
    """``"line N: "`` for a part of the machine's file, from its keys' lines (empty when unknown)."""

    lines: dict[tuple[str, ...], int]
    prefix: tuple[str, ...]

    def at(self, *path: str) -> str:
        """The line of the deepest key of ``prefix + path`` that the file has."""
        full = (*self.prefix, *path)
        for end in range(len(full), 0, -1):
            if (line := self.lines.get(full[:end])) is not None:
                return f"line {line}: "
        return ""

    def of_state(self, states: dict[str, StateSpec], name: str, *rest: str) -> str:
        """The line of ``rest`` inside state ``name`` (nested under its superstates)."""
        chain: list[str] = []
        current: str | None = name
        while current is not None and current in states and current not in chain:
            chain.append(current)
            current = states[current].parent
        path = [part for state in reversed(chain) for part in ("states", state)]
        return self.at(*path, *rest)


def _flatten(
    states: dict[str, StateModel],
    parent: str | None,
    out: dict[str, StateSpec],
    problems: list[str],
    lines: _Lines,
    *,
    parallel_around: str | None = None,
    parent_parallel: bool = False,
) -> None:
    for name, model in states.items():
        at = _Lines(lines.lines, (*lines.prefix, "states", name)).at
        if name in out:
            first = out[name].parent
            places = [f"inside {p!r}" if p else "at the top level" for p in (first, parent)]
            problems.append(
                f"{at()}state {name!r}: defined twice, {places[0]} and {places[1]}; "
                "fix: state names must be unique across all levels, rename one"
            )
            continue
        children = tuple(model.states or ())
        if model.action is not None and children:
            problems.append(
                f"{at()}state {name!r}: has both an action and substates; fix: a state is either served "
                "by a module (action) or groups substates (states), move the action into a substate"
            )
        if model.action is None and not children:
            problems.append(
                f"{at()}state {name!r}: has no action; fix: add 'action: <module>/<server>' naming the "
                "module's action server"
            )
        initial = model.initial
        if initial is not None and not children:
            problems.append(
                f"{at()}state {name!r}: sets initial {initial!r} but has no substates; fix: remove 'initial:' "
                "(only a superstate, one with 'states:', has an initial substate)"
            )
        problems.extend(_parallel_problems(name, model, parallel_around, parent_parallel, at))
        if model.parallel and model.states and initial is None:
            # entering it enters every region; machine.enter() stands for that with the first one
            initial = max(children, key=lambda child: (model.states or {})[child].priority or 0)
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
            parallel=model.parallel,
            priority=model.priority or 0,
        )
        if model.states:
            _flatten(
                model.states,
                name,
                out,
                problems,
                _Lines(lines.lines, (*lines.prefix, "states", name)),
                parallel_around=name if model.parallel else parallel_around,
                parent_parallel=model.parallel,
            )


def _parallel_problems(
    name: str, model: StateModel, parallel_around: str | None, parent_parallel: bool, at: Callable[..., str]
) -> list[str]:
    problems: list[str] = []
    regions = len(model.states or ())
    if model.parallel and parallel_around is not None:
        problems.append(
            f"{at('parallel')}state {name!r}: a parallel state inside parallel state {parallel_around!r}; "
            "fix: parallel states do not nest: make it a plain superstate, or move its regions up into "
            f"{parallel_around!r}"
        )
    if model.parallel and regions < 2:
        problems.append(
            f"{at('parallel')}state {name!r}: parallel with {regions} region(s); fix: give it at least two "
            "substates (its regions, each with a priority), or remove 'parallel: true'"
        )
    if model.parallel and model.initial is not None:
        problems.append(
            f"{at('initial')}state {name!r}: a parallel state sets initial {model.initial!r}; fix: remove "
            "'initial:' (every region starts when it is entered; set 'initial:' inside a region instead)"
        )
    if parent_parallel and model.priority is None:
        problems.append(
            f"{at()}state {name!r}: a region of parallel state {parallel_around!r} without a priority; fix: "
            "add 'priority: <whole number>' (the higher wins an arbitrated resource)"
        )
    if not parent_parallel and model.priority is not None:
        problems.append(
            f"{at('priority')}state {name!r}: sets priority {model.priority} but is no region of a parallel "
            "state; fix: remove 'priority:' (only the substates of a state with 'parallel: true' have one)"
        )
    return problems
