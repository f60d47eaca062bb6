"""The static check of parallel states: can two regions ever hold an exclusive resource at once?

It explores every configuration the robot can reach from its initial state when any event
may arrive at any time: every event some active state takes (as if sent on the event topic),
and every module's ``succeeded`` or ``aborted``. Configurations are stepped exactly as the
controller steps them (:meth:`cyborg.controller.regions.Regions.step`). The search is breadth
first, so the trace reported for each clash is a shortest one. Pure: no I/O.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
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
    if not regions.parallels:
        return Exploration(configurations=len(machine.reachable()), parallel_configurations=0, clashes=())
    tables = _Tables(machine, regions)
    start = regions.configuration(machine.enter(machine.initial))
    came_from: dict[_Config, tuple[_Config, str, str | None] | None] = {start: None}
    queue: deque[_Config] = deque([start])
    clashes: dict[tuple[str, _Config], Clash] = {}
    in_parallel = 0
    exclusive = tables.exclusive
    for config in _drain(queue):
        if len(config) > 1:
            in_parallel += 1
            held: set[str] = set()
            for leaf in config:
                mine = exclusive.get(leaf)
                if mine:
                    if not held.isdisjoint(mine):
                        _record_clashes(machine, regions, config, came_from, clashes)
                        break
                    held |= mine
            for event, source, following in tables.successors(config):
                if following not in came_from:
                    came_from[following] = (config, event, source)
                    queue.append(following)
        else:
            for event, following in tables.plain[config[0]]:
                if following not in came_from:
                    came_from[following] = (config, event, None)
                    queue.append(following)
    return Exploration(len(came_from), in_parallel, tuple(clashes.values()))


def _drain(queue: deque[_Config]) -> Iterator[_Config]:
    while queue:
        yield queue.popleft()


class _Tables:
    """Each leaf's moves, precomputed so that stepping a configuration is a few dictionary lookups.

    They give what :meth:`Regions.step` gives (tests/controller/test_clashes.py compares them).
    """

    def __init__(self, machine: MachineSpec, regions: Regions) -> None:
        self.plain: dict[str, list[tuple[str, _Config]]] = {}
        # leaf in a region -> event -> its region's next leaf (str), or the configuration left for (tuple)
        self.inner: dict[str, dict[str, str | _Config]] = {}
        self.outer: dict[str, dict[str, _Config]] = {}  # parallel state -> event -> configuration
        self.exclusive: dict[str, frozenset[str]] = {}
        self.results: dict[str, list[tuple[str, str | _Config]]] = {}  # leaf -> its module's results
        for leaf in machine.leaves():
            name = leaf.name
            parallel = regions.parallel_of(name)
            if parallel is None:
                self.plain[name] = [
                    (event, regions.configuration(target))
                    for event, target in machine.transitions_of(name).items()
                ]
                continue
            region = regions.region_of(name)
            assert region is not None
            table: dict[str, str | _Config] = {}
            for event, target in regions.inner_transitions(name).items():
                entered = machine.enter(target)
                table[event] = entered if regions.inside(target, region) else regions.configuration(entered)
            self.inner[name] = table
            outer = self.outer.setdefault(
                parallel,
                {
                    event: regions.configuration(machine.enter(target))
                    for event, target in regions.outer_transitions(parallel).items()
                },
            )
            results: list[tuple[str, str | _Config]] = []
            for result in (SUCCEEDED, ABORTED):  # as Regions.step with the result's source, then 'aborted'
                found = table.get(result) or outer.get(result) or table.get(ABORTED) or outer.get(ABORTED)
                if found is not None:
                    results.append((result, found))
            self.results[name] = results
            self.exclusive[name] = frozenset(
                r for r in regions.inner_resources(name) if machine.policy(r) is ResourcePolicy.EXCLUSIVE
            )
        self.parallel_of = {leaf: regions.parallel_of(leaf) for leaf in self.inner}

    def successors(self, config: _Config) -> list[tuple[str, str | None, _Config]]:
        """(event, the leaf whose module's result it is or None, next configuration) of a parallel one."""
        if len(config) == 2:
            return self._pair_successors(config)
        out: list[tuple[str, str | None, _Config]] = []
        moves: dict[str, list[tuple[int, str | _Config]]] = {}  # in priority order: traces must not vary
        for index, leaf in enumerate(config):
            for event, target in self.inner[leaf].items():
                taken = moves.get(event)
                if taken is None:
                    moves[event] = [(index, target)]
                else:
                    taken.append((index, target))
        for event, taken in moves.items():
            exit_to = next((t for _, t in taken if isinstance(t, tuple)), None)
            if exit_to is not None:  # the highest-priority region leaving the parallel state wins
                out.append((event, None, exit_to))
                continue
            moved = list(config)
            for index, target in taken:
                moved[index] = target  # type: ignore[assignment]  # a leaf, not an exit
            out.append((event, None, tuple(moved)))
        for event, target in self.outer[self.parallel_of[config[0]]].items():  # type: ignore[index]
            if event not in moves:
                out.append((event, None, target))
        for index, leaf in enumerate(config):  # a module's result goes to its own region only
            for result, result_target in self.results[leaf]:
                if isinstance(result_target, tuple):
                    out.append((result, leaf, result_target))
                else:
                    out.append((result, leaf, (*config[:index], result_target, *config[index + 1 :])))
        return out

    def _pair_successors(self, config: _Config) -> list[tuple[str, str | None, _Config]]:
        """:meth:`successors` of two regions, the common case, without the general bookkeeping."""
        first, second = config
        mine, theirs = self.inner[first], self.inner[second]
        out: list[tuple[str, str | None, _Config]] = []
        for event, target in mine.items():
            other = theirs.get(event)
            if isinstance(target, tuple):
                out.append((event, None, target))
            elif other is None:
                out.append((event, None, (target, second)))
            elif isinstance(other, tuple):
                out.append((event, None, other))
            else:
                out.append((event, None, (target, other)))
        for event, other in theirs.items():
            if event not in mine:
                out.append((event, None, other if isinstance(other, tuple) else (first, other)))
        for event, exit_to in self.outer[self.parallel_of[first]].items():  # type: ignore[index]
            if event not in mine and event not in theirs:
                out.append((event, None, exit_to))
        for result, target in self.results[first]:
            out.append((result, first, target if isinstance(target, tuple) else (target, second)))
        for result, target in self.results[second]:
            out.append((result, second, target if isinstance(target, tuple) else (first, target)))
        return out


def _record_clashes(
    machine: MachineSpec,
    regions: Regions,
    config: _Config,
    came_from: dict[_Config, tuple[_Config, str, str | None] | None],
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


def _trace(
    came_from: dict[_Config, tuple[_Config, str, str | None] | None], config: _Config
) -> tuple[str, ...]:
    labels: list[str] = []
    link = came_from[config]
    while link is not None:
        config, event, source = link
        labels.append(event if source is None else f"{source}: {event}")
        link = came_from[config]
    return tuple(reversed(labels))
