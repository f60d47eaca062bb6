"""Plans the simulated base's next wander trip on another thread while it drives this one.

Part of the simulation layer, beside :mod:`cyborg.sim.planner`. A wandering base drives to a
random point, then to the next, and so on. Its next trip is known while it drives: it starts
where this one ends and goes to the point its random generator would give next. The A*
search (pyastar2d, in C++, which lets go of Python's lock) can then run on a second core
during the drive instead of stopping the whole simulation when the trip begins (issue 18:
a simulated 8-hour day plans about 300 trips).

Nothing changes where the robot goes: :meth:`RouteLookahead.route` uses a prepared route only
when its start and goal are exactly the ones asked for (the same inputs give the same route),
and plans on the spot otherwise, e.g. when another component drew from the shared random
generator in between, or a goal interrupted the wander.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor

from cyborg.maps import Point
from cyborg.sim.planner import Route, RoutePlanner

__all__ = ["RouteLookahead", "arrival"]

log = logging.getLogger(__name__)


def arrival(waypoints: Sequence[Point]) -> Point:
    """Where a base that drives ``waypoints`` leg by leg ends, to the last bit of the floats.

    Each leg ends at ``start + (waypoint - start) * 1.0`` (see ``SimulatedBase._drive_leg``),
    which can differ from the waypoint in the last binary digit; a leg shorter than 1e-9 m is
    not driven.
    """
    x, y = waypoints[0]
    for wx, wy in waypoints[1:]:
        dx, dy = wx - x, wy - y
        if math.hypot(dx, dy) < 1e-9:
            continue
        x, y = x + dx * 1.0, y + dy * 1.0
    return x, y


class RouteLookahead:
    """The routes of a base: the next one prepared on a thread of its own, the others on the spot."""

    def __init__(self, planner: RoutePlanner) -> None:
        self.planner = planner
        self.hits = 0
        """Routes that came ready from the thread."""
        self.misses = 0
        """Routes planned on the spot while another was prepared (its start or goal differed)."""
        self._thread: ThreadPoolExecutor | None = None
        self._prepared: tuple[Point, Point, Future[Route]] | None = None

    def prepare(self, start: Point, goal: Point) -> None:
        """Start planning from ``start`` to ``goal`` on the lookahead thread (replaces what was prepared)."""
        if self._thread is None:
            self._thread = ThreadPoolExecutor(1, thread_name_prefix="route-lookahead")
        self._drop()
        self._prepared = (start, goal, self._thread.submit(self.planner.plan, start, goal))

    def route(self, start: Point, goal: Point) -> Route:
        """The route from ``start`` to ``goal``: the prepared one if it is for exactly these, else
        planned now. Raises :class:`~cyborg.errors.PlanningError` as the planner does."""
        prepared, self._prepared = self._prepared, None
        if prepared is not None:
            if prepared[0] == start and prepared[1] == goal:
                self.hits += 1
                return prepared[2].result()  # usually done: it ran while the base drove
            prepared[2].cancel()
            self.misses += 1
        return self.planner.plan(start, goal)

    def close(self) -> None:
        """Forget what was prepared and stop the thread (a search under way finishes on its own)."""
        self._drop()
        if self._thread is not None:
            self._thread.shutdown(wait=False, cancel_futures=True)
            self._thread = None

    def _drop(self) -> None:
        if self._prepared is not None:
            self._prepared[2].cancel()
            self._prepared = None
