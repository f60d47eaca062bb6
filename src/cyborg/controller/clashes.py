"""The static check of parallel states: can two regions ever hold an exclusive resource at once?

It explores every configuration the robot can reach from its initial state when any event
may arrive at any time: every event some active state takes (as if sent on the event topic),
and every module's ``succeeded`` or ``aborted``. Configurations are stepped exactly as the
controller steps them (:meth:`cyborg.controller.regions.Regions.step`). The search is breadth
first, so the trace reported for each clash is a shortest one. Pure: no I/O.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from cyborg.controller.machine import ABORTED, SUCCEEDED, MachineSpec, ResourcePolicy
from cyborg.controller.regions import Regions

__all__ = ["Clash", "Exploration", "explore"]

_Config = tuple[str, ...]


@dataclass(frozen=True)
class Clash:
    """Two or more regions of ``parallel`` hold the exclusive ``resource`` in ``states``."""

    parallel: str
    resource: str
    states: tuple[str, ...]
    regions: tuple[str, ...]
    trace: tuple[str, ...]
    """The events that lead there from the start, shortest first found (``state: succeeded`` for a module's result)."""

    def describe(self) -> str:
        """One "what; fix" line."""
        regions = " and ".join(repr(r) for r in self.regions)
        states = " and ".join(repr(s) for s in self.states)
        return (
            f"parallel state {self.parallel!r}: regions {regions} both hold the exclusive resource "
            f"{self.resource!r} (states {states}), reached by {' -> '.join(('start', *self.trace))}; "
            f"fix: grant {self.resource!r} in one region only, or let the higher-priority region win it "
            f"with resource_policy: {{{self.resource}: arbitrated}}"
        )


@dataclass(frozen=True)
class Exploration:
    """What the check found: the reachable configurations and the clashes among them."""

    configurations: int
    parallel_configurations: int
    clashes: tuple[Clash, ...]


def explore(machine: MachineSpec, regions: Regions | None = None) -> Exploration:
    """Every reachable configuration, and each distinct exclusive clash with a shortest trace."""
    regions = regions or Regions(machine)
    start = regions.configuration(machine.enter(machine.initial))
    if not regions.parallels:
        return Exploration(configurations=len(machine.reachable()), parallel_configurations=0, clashes=())
    events = {leaf.name: tuple(machine.transitions_of(leaf.name)) for leaf in machine.leaves()}
    came_from: dict[_Config, tuple[_Config, str] | None] = {start: None}
    queue: deque[_Config] = deque([start])
    clashes: dict[tuple[str, _Config], Clash] = {}
    in_parallel = 0
    while queue:
        config = queue.popleft()
        if len(config) > 1 or regions.parallel_of(config[0]) is not None:
            in_parallel += 1
            _record_clashes(machine, regions, config, came_from, clashes)
        for label, following in _successors(regions, config, events):
            if following not in came_from:
                came_from[following] = (config, label)
                queue.append(following)
    return Exploration(len(came_from), in_parallel, tuple(clashes.values()))


def _successors(
    regions: Regions, config: _Config, events: dict[str, tuple[str, ...]]
) -> list[tuple[str, _Config]]:
    out: list[tuple[str, _Config]] = []
    seen: set[str] = set()
    for leaf in config:
        for event in events[leaf]:
            if event in seen:
                continue
            seen.add(event)
            step = regions.step(config, event)
            if step is not None:
                out.append((event, step.leaves))
    if len(config) > 1:  # a module's result goes to its own region only (elsewhere it is an event above)
        for leaf in config:
            for result in (SUCCEEDED, ABORTED):
                step = regions.step(config, result, leaf) or regions.step(config, ABORTED, leaf)
                if step is not None:
                    out.append((f"{leaf}: {result}", step.leaves))
    return out


def _record_clashes(
    machine: MachineSpec,
    regions: Regions,
    config: _Config,
    came_from: dict[_Config, tuple[_Config, str] | None],
    clashes: dict[tuple[str, _Config], Clash],
) -> None:
    for resource, holding in regions.holders(config).items():
        if len(holding) < 2 or machine.policy(resource) is not ResourcePolicy.EXCLUSIVE:
            continue
        states = tuple(leaf for leaf, _ in holding)
        key = (resource, states)
        if key in clashes:
            continue
        parallel = regions.parallel_of(config[0])
        assert parallel is not None
        clashes[key] = Clash(
            parallel=parallel,
            resource=resource,
            states=states,
            regions=tuple(regions.region_of(leaf) or leaf for leaf in states),
            trace=_trace(came_from, config),
        )


def _trace(came_from: dict[_Config, tuple[_Config, str] | None], config: _Config) -> tuple[str, ...]:
    labels: list[str] = []
    link = came_from[config]
    while link is not None:
        config, label = link
        labels.append(label)
        link = came_from[config]
    return tuple(reversed(labels))
