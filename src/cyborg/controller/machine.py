"""Pure state-machine logic: states, hierarchy and transition lookup.

A :class:`MachineSpec` is the validated, immutable form of the YAML file.
Leaf states are the ones a module serves (they have an action server);
superstates group leaf states and lend them their transitions and resources
(a Harel-style hierarchy). Entering a superstate enters its initial substate.
No I/O here: the controller runtime wires this to the transport.
"""

from __future__ import annotations

import enum
from collections import deque
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

ABORTED = "aborted"
SUCCEEDED = "succeeded"


@dataclass(frozen=True)
class StateSpec:
    """One state. ``action`` is None for a superstate, which has ``children``."""

    name: str
    action: str | None
    transitions: Mapping[str, str]
    resources: Mapping[str, str]
    parent: str | None = None
    initial: str | None = None
    children: tuple[str, ...] = ()
    description: str = ""
    parallel: bool = False
    """A superstate whose children (regions) all run at once (see :mod:`cyborg.controller.regions`)."""
    priority: int = 0
    """A region's rank in its parallel state: the higher wins an arbitrated resource."""

    @property
    def is_leaf(self) -> bool:
        return self.action is not None


class ResourcePolicy(enum.StrEnum):
    """What two regions of a parallel state holding one resource at once means."""

    EXCLUSIVE = "exclusive"
    """Never allowed: validation refuses a machine where it can happen."""
    ARBITRATED = "arbitrated"
    """Allowed: the higher-priority region's node gets it, the other is muted."""


@dataclass(frozen=True)
class Timeouts:
    connect: float = 2.0
    preempt: float = 2.0
    event_age: float = 10.0  # seconds an event may wait in the controller's queue


@dataclass(frozen=True)
class MachineSpec:
    """All states by name, the initial state and the timeouts."""

    states: Mapping[str, StateSpec]
    initial: str
    timeouts: Timeouts = field(default_factory=Timeouts)
    resource_policy: Mapping[str, ResourcePolicy] = field(default_factory=dict)
    """Per resource; one not listed is exclusive."""

    def policy(self, resource: str) -> ResourcePolicy:
        return self.resource_policy.get(resource, ResourcePolicy.EXCLUSIVE)

    def ancestors(self, name: str) -> Iterator[StateSpec]:
        """The state itself, then its superstates outwards."""
        state: StateSpec | None = self.states[name]
        while state is not None:
            yield state
            state = self.states[state.parent] if state.parent else None

    def enter(self, name: str) -> str:
        """The leaf state actually entered when ``name`` is the target."""
        state = self.states[name]
        while not state.is_leaf:
            assert state.initial is not None, f"superstate {state.name} has no initial substate"
            state = self.states[state.initial]
        return state.name

    def lookup(self, state: str, event: str) -> str | None:
        """The leaf state that ``event`` leads to from ``state``, or None if it is no transition."""
        for scope in self.ancestors(state):
            target = scope.transitions.get(event)
            if target is not None:
                return self.enter(target)
        return None

    def transitions_of(self, state: str) -> dict[str, str]:
        """Every event valid in ``state`` (own ones win over inherited ones) -> leaf target."""
        merged: dict[str, str] = {}
        for scope in self.ancestors(state):
            for event, target in scope.transitions.items():
                merged.setdefault(event, self.enter(target))
        return merged

    def resources_of(self, state: str) -> dict[str, str]:
        """Resources of ``state`` including those its superstates grant."""
        merged: dict[str, str] = {}
        for scope in self.ancestors(state):
            for resource, node in scope.resources.items():
                merged.setdefault(resource, node)
        return merged

    def companions(self, leaf: str) -> list[str]:
        """The initial leaves of the other regions when ``leaf`` is in a parallel state's region."""
        child = leaf
        for scope in self.ancestors(leaf):
            if scope.parallel:
                return [self.enter(region) for region in scope.children if region != child]
            child = scope.name
        return []

    def leaves(self) -> list[StateSpec]:
        return [s for s in self.states.values() if s.is_leaf]

    def reachable(self) -> set[str]:
        """Leaf states reachable from the initial state (plus their superstates)."""
        start = self.enter(self.initial)
        seen = {start}
        queue = deque([start])
        while queue:
            current = queue.popleft()
            targets = list(self.transitions_of(current).values())
            targets.extend(self.companions(current))
            for target in targets:
                if target not in seen:
                    seen.add(target)
                    queue.append(target)
        with_parents = set(seen)
        for leaf in seen:
            with_parents.update(s.name for s in self.ancestors(leaf))
        return with_parents
