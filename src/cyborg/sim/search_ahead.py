"""Route searches made ahead of need on a second process, for the simulated base in virtual time.

Part of the simulation layer, beside :mod:`cyborg.sim.base`. On a virtual clock that runs as
fast as it can (``--speed max``), the route planner's A* search is the largest single cost of a
simulated day, and the base waits for it at the start of every trip. A wandering base draws its
next targets from its random source, so they can be known before they are drawn: a copy of the
source's state gives them. :class:`SearchAhead` hands the searches of the next few wander trips to
one worker process while the base drives, and :meth:`RoutePlanner.plan
<cyborg.sim.planner.RoutePlanner.plan>` takes a search's path from it when it is the very
search the planner would make (the same area, the same two cells), else searches as before. The
worker runs :func:`~cyborg.sim.planner.search_area` on the same weights, so every route is the
same as without it: only where the time is spent changes.

The worker is started at the first wander trip (a process that holds one free area's weights,
made from its blocked cells sent as bits) and stopped by :meth:`SearchAhead.close`. If
it cannot start or dies, the base logs it once and searches by itself. Closing the clock stops it
too, for a base that is never closed.
"""

from __future__ import annotations

import logging
import multiprocessing
import random
from collections import OrderedDict
from concurrent.futures import Future, ProcessPoolExecutor
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cyborg.sim._search_worker import prepare_worker, search_in_worker
from cyborg.sim.planner import AreaSearch, Location, RoutePlanner
from cyborg.transport.clock import Clock

__all__ = ["SearchAhead"]

log = logging.getLogger(__name__)

_KEPT = 8
"""Searches kept waiting for their trip; older ones were not needed (a wander that ended)."""


class SearchAhead:
    """Searches the next ``trips`` wander trips of a base on a worker process (see the module).

    Call :meth:`foresee_wander` when a wander trip starts; pass the object as ``searched`` to
    :meth:`RoutePlanner.plan`; :meth:`close` (or closing ``clock``) stops the worker.
    """

    def __init__(self, planner: RoutePlanner, clock: Clock, trips: int = 2) -> None:
        self.planner = planner
        self.clock = clock
        self.trips = trips
        self._pool: ProcessPoolExecutor | None = None
        self._area_sent: int | None = None
        self._pending: OrderedDict[AreaSearch, Future[Any]] = OrderedDict()
        self._broken = False
        self.used = 0
        """Searches the planner took from the worker."""

    def foresee_wander(self, rng: random.Random, target: Location) -> None:
        """A wander trip to ``target`` starts: search the next trips, drawn from a copy of ``rng``."""
        if self._broken:
            return
        peek = random.Random()
        peek.setstate(rng.getstate())
        here = target
        for _ in range(self.trips):
            there = self.planner.random_reachable_point(peek, near=here)
            search = self.planner.area_search(here, there)
            if search is not None and search not in self._pending:
                self._submit(search)
            here = there

    def __call__(self, search: AreaSearch) -> NDArray[np.int32] | None:
        """The path of ``search`` if the worker was given it (waiting for it if need be), else None."""
        future = self._pending.pop(search, None)
        if future is None:
            return None
        try:
            path: NDArray[np.int32] | None = future.result()
        except Exception as exc:  # the worker died: search here from now on
            self._give_up(exc)
            return None
        self.used += 1
        return path

    def close(self) -> None:
        """Stop the worker; searches not taken are dropped."""
        self._broken = True
        self._pending.clear()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def _submit(self, search: AreaSearch) -> None:
        try:
            if self._pool is None:
                self.clock.on_close(self.close)  # a base that is never closed still stops its worker
                self._pool = ProcessPoolExecutor(
                    1, mp_context=multiprocessing.get_context("spawn"), initializer=prepare_worker
                )
            blocked = None
            if search.area != self._area_sent:  # 1 bit a cell: an eighth of a MB for the campus
                cells = self.planner.area_blocked(search.area)
                blocked = (np.packbits(cells, axis=None), (int(cells.shape[0]), int(cells.shape[1])))
                self._area_sent = search.area
            future = self._pool.submit(search_in_worker, search.area, blocked, search.start, search.goal)
        except Exception as exc:
            self._give_up(exc)
            return
        self._pending[search] = future
        while len(self._pending) > _KEPT:
            self._pending.popitem(last=False)[1].cancel()

    def _give_up(self, exc: BaseException) -> None:
        log.warning(
            "searching routes ahead on a second process failed (%s: %s); the base searches each "
            "route itself from now on (the same routes, only slower)",
            type(exc).__name__,
            exc,
        )
        self.close()
