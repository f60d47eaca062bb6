"""Where module factories build: the data folder, the seeded randomness and the map.

Kept apart from :mod:`cyborg.app.robot` so that the ROS node of one module imports neither
the controller nor the emotion system nor the motivator.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from cyborg.modules.kind import CalendarEntry, KeepsCalendar

if TYPE_CHECKING:
    from cyborg.maps import OccupancyMap

__all__ = ["BuildPlace", "calendar_of"]


@dataclass
class BuildPlace:
    """What module factories may use besides their node (a :class:`~cyborg.modules.kind.BuildContext`)."""

    data_dir: Path
    rng: random.Random = field(default_factory=lambda: random.Random(0))
    map_path: Path | None = None
    _map: OccupancyMap | None = field(default=None, repr=False)

    def occupancy_map(self) -> OccupancyMap:
        """The map of the world (``--map`` or the packaged campus), loaded once."""
        if self._map is None:
            from cyborg.maps import default_map_path, load_map

            self._map = load_map(self.map_path or default_map_path())
        return self._map


def calendar_of(components: Iterable[object]) -> Callable[[CalendarEntry], None] | None:
    """The calendar of the first component that keeps one."""
    for component in components:
        if isinstance(component, KeepsCalendar):
            return component.add_calendar_entry
    return None
