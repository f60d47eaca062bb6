"""Review 9.12 (WEAK): a map whose start point lies on a wall (no home, no goals: the middle of the
map, here a wall across it). Every wander logged "Task exception was never retrieved ...
PlanningError: start (120.0, 120.0) is inside a wall" with a traceback, and the robot sat in
navigation_moving without moving. Now the simulated base starts at the nearest free place and
says so in one warning, and it wanders from there."""

from __future__ import annotations

import logging
import random
from pathlib import Path

import pytest

from cyborg.maps import load_map
from cyborg.sim.base import SimulatedBase
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport

MAP = "\n".join(
    ["2D-Map", "MinPos: 0 0", "MaxPos: 20000 20000", "NumPoints: 2", "NumLines: 1", "LINES",
     "0 10000 20000 10000", "DATA", "0 0", "20000 20000", ""]
)  # fmt: skip


def test_a_start_on_a_wall_moves_to_the_nearest_free_place_and_wanders(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "line.map"
    path.write_text(MAP)
    occupancy = load_map(path)
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    try:
        with caplog.at_level(logging.WARNING):
            base = SimulatedBase(transport.node("rosarnl_node"), occupancy, rng=random.Random(1))
            assert base.planner.is_free(base.x, base.y)
            assert abs(base.x - 10.0) < 1.0 and abs(base.y - 10.0) < 1.0, (base.x, base.y)
            start = (base.x, base.y)
            base._on_wander(None, None)  # type: ignore[arg-type]
            clock.run(clock.sleep(60))
            assert base.distance_travelled > 1.0, "the base did not wander"
            assert (base.x, base.y) != start
            base.close()
        lines = [r.getMessage() for r in caplog.records]
        assert any("inside a wall" in line and "nearest free place" in line for line in lines), lines
        assert not any(r.exc_info for r in caplog.records), lines
    finally:
        transport.shutdown()
        clock.close()
