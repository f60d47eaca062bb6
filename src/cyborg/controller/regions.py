"""Parallel states: which leaves are active together, where an event takes them, who holds what.

A superstate with ``parallel: true`` runs all its children (its *regions*) at once; each
region has a ``priority`` (higher first, ties are refused by validation). While the robot is
in a parallel state its *configuration* is one active leaf per region, in priority order; in
any other state it is that one leaf.

How an event moves a configuration (:meth:`Regions.step`), the same at run time and in the
static check (:mod:`cyborg.controller.clashes`):

1. Each region, highest priority first, looks the event up in its active leaf and the
   superstates around it up to and including the region.
2. If one of those transitions leads out of the parallel state, the highest-priority such
   region's transition is taken: every region is left and the target entered.
3. Otherwise every region that has the event moves (the others keep running, untouched).
4. If no region has it, the parallel state's own transitions (and its superstates') apply,
   and taking one leaves every region.

A module's result (``succeeded``/``aborted``) goes to its own region only. Resources granted
inside a region belong to that region; the parallel state's own (and its superstates') belong
to all of it. For each resource the highest-priority region that holds it gets it; the others
holding it are *muted* (:meth:`Regions.arbitrate`). Pure: no I/O.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from cyborg.controller.machine import MachineSpec, ResourcePolicy

__all__ = ["Lanes", "Mute", "Regions", "ResourcePolicy", "Step"]


@dataclass(frozen=True)
class Step:
    """Where an event takes a configuration."""

    leaves: tuple[str, ...]
    """The new configuration: one leaf, or one per region of a parallel state in priority order."""
    moved: tuple[int, ...]
    """Indices into ``leaves`` whose module gets a new goal (all of them when ``whole``)."""
    whole: bool
    """The old configuration is left as a whole (a plain transition, or into or out of a parallel state)."""


@dataclass(frozen=True)
class Mute:
    """A region's node that holds ``resource`` but is outranked by a higher-priority region."""

    resource: str
    node: str
    state: str
    region: str
    holder: str
    """The node the resource is granted to instead."""

    def as_dict(self) -> dict[str, str]:
        return {
            "resource": self.resource,
            "node": self.node,
            "state": self.state,
            "region": self.region,
            "holder": self.holder,
        }


class Regions:
    """A machine's parallel states, precomputed for fast stepping."""

    def __init__(self, machine: MachineSpec) -> None:
        self.machine = machine
        states = machine.states
        self.parallels: tuple[str, ...] = tuple(name for name, s in states.items() if s.parallel)
        self._regions: dict[str, tuple[str, ...]] = {
            p: tuple(sorted(states[p].children, key=lambda r: -states[r].priority)) for p in self.parallels
        }
        self._parallel_of: dict[str, str] = {}
        self._region_of: dict[str, str] = {}
        self._index: dict[str, int] = {}
        self._inner: dict[str, dict[str, str]] = {}  # leaf in a region -> event -> target (region scope)
        self._outer: dict[str, dict[str, str]] = {}  # parallel state -> event -> target (it and outwards)
        self._inner_resources: dict[str, dict[str, str]] = {}
        self._outer_resources: dict[str, dict[str, str]] = {}
        for parallel, regions in self._regions.items():
            self._outer[parallel] = _merged(machine, parallel, None, "transitions")
            self._outer_resources[parallel] = _merged(machine, parallel, None, "resources")
            for index, region in enumerate(regions):
                for leaf in self._leaves_under(region):
                    self._parallel_of[leaf] = parallel
                    self._region_of[leaf] = region
                    self._index[leaf] = index
                    self._inner[leaf] = _merged(machine, leaf, parallel, "transitions")
                    self._inner_resources[leaf] = _merged(machine, leaf, parallel, "resources")

    def _leaves_under(self, name: str) -> list[str]:
        state = self.machine.states[name]
        if state.is_leaf:
            return [name]
        return [leaf for child in state.children for leaf in self._leaves_under(child)]

    # --- structure ---------------------------------------------------------------------

    def parallel_of(self, leaf: str) -> str | None:
        """The parallel state ``leaf`` runs in, or None."""
        return self._parallel_of.get(leaf)

    def region_of(self, leaf: str) -> str | None:
        return self._region_of.get(leaf)

    def regions(self, parallel: str) -> tuple[str, ...]:
        """The regions of ``parallel``, highest priority first."""
        return self._regions[parallel]

    def configuration(self, leaf: str) -> tuple[str, ...]:
        """The configuration entered when ``leaf`` is the target: the other regions start at their initial leaf."""
        parallel = self._parallel_of.get(leaf)
        if parallel is None:
            return (leaf,)
        mine = self._region_of[leaf]
        return tuple(leaf if r == mine else self.machine.enter(r) for r in self._regions[parallel])

    def inner_transitions(self, leaf: str) -> dict[str, str]:
        """Transitions of a region's ``leaf`` and its superstates up to the region: event -> target."""
        return self._inner[leaf]

    def inner_resources(self, leaf: str) -> dict[str, str]:
        """Resources a region's ``leaf`` holds as that region's (its own and up to the region)."""
        return self._inner_resources[leaf]

    def outer_transitions(self, parallel: str) -> dict[str, str]:
        """Transitions of ``parallel`` itself and its superstates: event -> target."""
        return self._outer[parallel]

    def inside(self, state: str, region: str) -> bool:
        """Whether ``state`` is ``region`` or nested in it."""
        current: str | None = state
        while current is not None:
            if current == region:
                return True
            current = self.machine.states[current].parent
        return False

    # --- events ------------------------------------------------------------------------

    def takes(self, leaves: tuple[str, ...], event: str) -> bool:
        """Whether ``event`` is a transition anywhere in the configuration."""
        return any(self.machine.lookup(leaf, event) is not None for leaf in leaves)

    def step(self, leaves: tuple[str, ...], event: str, source: str | None = None) -> Step | None:
        """Where ``event`` takes ``leaves`` (see the module docstring); None if it is no transition.

        ``source``: the leaf whose module's result the event is (it then goes to that region only).
        """
        parallel = self._parallel_of.get(leaves[0])
        if parallel is None:
            target = self.machine.lookup(leaves[0], event)
            return None if target is None else self._enter(target)
        new = list(leaves)
        moved: list[int] = []
        for index, leaf in enumerate(leaves):
            if source is not None and leaf != source:
                continue
            target = self._inner[leaf].get(event)
            if target is None:
                continue
            if not self.inside(target, self._region_of[leaf]):
                return self._enter(self.machine.enter(target))
            new[index] = self.machine.enter(target)
            moved.append(index)
        if moved:
            return Step(tuple(new), tuple(moved), whole=False)
        target = self._outer[parallel].get(event)
        return None if target is None else self._enter(self.machine.enter(target))

    def _enter(self, leaf: str) -> Step:
        leaves = self.configuration(leaf)
        return Step(leaves, tuple(range(len(leaves))), whole=True)

    # --- resources ---------------------------------------------------------------------

    def holders(self, leaves: tuple[str, ...]) -> dict[str, list[tuple[str, str]]]:
        """Per resource, the (leaf, node) of each region holding it, highest priority first."""
        out: dict[str, list[tuple[str, str]]] = {}
        if self._parallel_of.get(leaves[0]) is None:
            return out
        for leaf in leaves:
            for resource, node in self._inner_resources[leaf].items():
                out.setdefault(resource, []).append((leaf, node))
        return out

    def arbitrate(self, leaves: tuple[str, ...]) -> tuple[dict[str, str], list[Mute]]:
        """The resources granted in ``leaves`` (resource -> node) and the muted holders."""
        parallel = self._parallel_of.get(leaves[0])
        if parallel is None:
            return self.machine.resources_of(leaves[0]), []
        granted = dict(self._outer_resources[parallel])
        mutes: list[Mute] = []
        for resource, holding in self.holders(leaves).items():
            (_, winner), *others = holding
            granted[resource] = winner
            mutes.extend(
                Mute(resource, node, leaf, self._region_of[leaf], winner)
                for leaf, node in others
                if node != winner
            )
        return granted, mutes


def _merged(machine: MachineSpec, name: str, stop: str | None, key: str) -> dict[str, str]:
    """``transitions`` or ``resources`` of ``name`` and its superstates up to (not including) ``stop``."""
    merged: dict[str, str] = {}
    for scope in machine.ancestors(name):
        if scope.name == stop:
            break
        values: Mapping[str, str] = scope.transitions if key == "transitions" else scope.resources
        for k, v in values.items():
            merged.setdefault(k, v)
    return merged


class Lanes:
    """The active state of each region, followed from ``state_change`` messages alone.

    A change into a region's state updates that region's lane (the others keep theirs); a change
    into a state outside every parallel state ends the lanes. Works the same in process and over
    ROS, where the controller's configuration is not on the wire (docs/parallel.md).
    """

    def __init__(self, regions: Regions) -> None:
        self.regions = regions
        self.parallel: str | None = None
        self.states: dict[str, str] = {}  # region -> its active state
        self.since: dict[str, float] = {}  # region -> when it entered that state

    def on_change(self, state: str, now: float) -> None:
        parallel = self.regions.parallel_of(state)
        if parallel is None:
            self.parallel, self.states, self.since = None, {}, {}
            return
        if parallel != self.parallel:
            self.parallel, self.states, self.since = parallel, {}, {}
        region = self.regions.region_of(state)
        assert region is not None
        self.states[region] = state
        self.since[region] = now

    def report(self, now: float) -> list[dict[str, object]]:
        """One entry per region, highest priority first: its state, time in it, muted resources."""
        if self.parallel is None:
            return []
        order = self.regions.regions(self.parallel)
        leaves = tuple(self.states.get(r) or self.regions.machine.enter(r) for r in order)
        _, mutes = self.regions.arbitrate(leaves)
        states = self.regions.machine.states
        return [
            {
                "region": region,
                "priority": states[region].priority,
                "state": self.states.get(region),
                "seconds_in_state": round(now - self.since[region], 1) if region in self.since else None,
                "muted": sorted(m.resource for m in mutes if m.region == region),
                "holds": sorted(self.regions.inner_resources(leaf)),
            }
            for region, leaf in zip(order, leaves, strict=True)
        ]
