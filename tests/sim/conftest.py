"""The packaged campus map and a route planner on it, for the simulated base's tests."""

from __future__ import annotations

import pytest

from cyborg.maps import OccupancyMap, default_map_path, load_map
from cyborg.sim.planner import RoutePlanner


@pytest.fixture(scope="module")
def campus() -> OccupancyMap:
    """The campus map shipped with the package (cyborg/data/maps/campus.map)."""
    return load_map(default_map_path())


@pytest.fixture(scope="module")
def campus_planner(campus: OccupancyMap) -> RoutePlanner:
    """A planner for the robot's footprint (0.35 m), built once a module: inflating the map is the slow part."""
    return RoutePlanner(campus, 0.35)
