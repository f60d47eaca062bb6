"""What module factories build with: the data folder, the seeded randomness, the map, the base's API.

One :class:`BuildContext` serves the in-process robot (:mod:`cyborg.app.robot`) and each ROS
node's part (:mod:`cyborg.app.parts`); it is what :class:`cyborg.modules.BuildContext` promises
a module's factory. Kept apart from :mod:`cyborg.app.robot` so that the ROS node of one module
imports neither the controller nor the emotion system nor the motivator.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from cyborg.modules.kind import Listening, listening_of
from cyborg.navigation.calendar import CalendarEntry, KeepsCalendar
from cyborg.transport.topics import BaseApi

if TYPE_CHECKING:
    from cyborg.app.registry import KindRegistry
    from cyborg.app.sketch import PartConfig
    from cyborg.maps import OccupancyMap

__all__ = ["BuildContext", "ModuleContext", "calendar_of", "heard_by", "relays_of"]


def relays_of(config: PartConfig) -> dict[str, tuple[str, ...]]:
    """Each gatekeeper's output topic -> the gatekeepers (node names) that publish on it."""
    relays: dict[str, tuple[str, ...]] = {}
    for gate in config.model.gatekeepers:
        topic = "/" + gate.output.strip().lstrip("/")
        relays[topic] = (*relays.get(topic, ()), gate.name)
    return relays


@dataclass
class BuildContext:
    """What module factories may use besides their node (a :class:`cyborg.modules.BuildContext`)."""

    data_dir: Path
    seed: int = 0
    """Seeds the robot's random source and each module's own (:meth:`for_module`)."""
    map_path: Path | None = None
    heard: Callable[[], Listening] | None = field(default=None, repr=False)
    """Gathers what the configured modules listen for (called on the first :meth:`listening`)."""
    resume: bool = True
    """The controller takes over an emotion stored recently (``cyborg node`` without ``--fresh``)."""
    base_api: BaseApi = BaseApi.ROSARNL
    """The robot base's interface, unless a module's settings name one (nav2's on ROS 2)."""
    relays: dict[str, tuple[str, ...]] | None = None
    """Output topic -> the configured gatekeepers that publish on it (None: no configuration)."""
    _map: OccupancyMap | None = field(default=None, repr=False)
    _listening: Listening | None = field(default=None, repr=False)
    _rng: random.Random | None = field(default=None, repr=False)

    @property
    def rng(self) -> random.Random:
        """The robot's random source, seeded with :attr:`seed` (a module draws from its own)."""
        if self._rng is None:
            self._rng = random.Random(self.seed)
        return self._rng

    def for_module(self, name: str) -> ModuleContext:
        """What module ``name``'s factory builds with: this context, and a random source of the
        module's own, seeded from :attr:`seed` and the name. A module so draws the same numbers
        whether the robot runs in one process or as one ROS node per part."""
        return ModuleContext(self, random.Random(f"{self.seed}:{name}"))

    def occupancy_map(self) -> OccupancyMap:
        """The map of the world (``--map``, else Glassgården if found, else the campus), loaded once."""
        if self._map is None:
            from cyborg.app.world import default_world
            from cyborg.maps import load_map

            self._map = load_map(self.map_path or default_world())
        return self._map

    def relays_to(self, topic: str) -> tuple[str, ...] | None:
        """The configured gatekeepers whose output is ``topic`` (None: built without a configuration)."""
        if self.relays is None:
            return None
        return self.relays.get("/" + topic.strip().lstrip("/"), ())

    def listening(self) -> Listening:
        """What the configured modules listen for in speech (nothing when built without a configuration)."""
        if self._listening is None:
            self._listening = self.heard() if self.heard is not None else Listening()
        return self._listening


@dataclass(frozen=True)
class ModuleContext:
    """One module's view of a :class:`BuildContext`: the robot's folder, map and ears, its own random source."""

    robot: BuildContext
    rng: random.Random

    @property
    def data_dir(self) -> Path:
        return self.robot.data_dir

    @property
    def base_api(self) -> BaseApi:
        return self.robot.base_api

    def occupancy_map(self) -> OccupancyMap:
        return self.robot.occupancy_map()

    def listening(self) -> Listening:
        return self.robot.listening()

    def relays_to(self, topic: str) -> tuple[str, ...] | None:
        return self.robot.relays_to(topic)


def heard_by(config: PartConfig, kinds: KindRegistry) -> Callable[[], Listening]:
    """What the modules of ``config`` listen for, gathered when first asked (it imports every module's kind)."""

    def gather() -> Listening:
        modules = config.model.modules
        return listening_of(kinds.parse(name, raw, source=config.source)[1] for name, raw in modules.items())

    return gather


def calendar_of(components: Iterable[object]) -> Callable[[CalendarEntry], None] | None:
    """The calendar of the first component that keeps one."""
    for component in components:
        if isinstance(component, KeepsCalendar):
            return component.add_calendar_entry
    return None
