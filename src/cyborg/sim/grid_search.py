"""A* on a free area's weights: the one search the route planner makes, in any process.

Part of the simulation layer, under :mod:`cyborg.sim.planner` (which cuts the weights to a free
area's box and pulls the path taut) and :mod:`cyborg.sim.search_ahead` (whose worker process runs
the same search ahead of need). It imports numpy and pyastar2d only, so that worker stays small.
Pure: the same weights and cells give the same path in any process.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyastar2d
from numpy.typing import NDArray

__all__ = ["search_area", "search_blocked_bits", "search_weights"]


def search_weights(blocked: NDArray[np.bool_]) -> NDArray[np.float32]:
    """A* weights for :func:`search_area`: inf on blocked cells, 1 on free ones."""
    made = np.where(blocked, np.float32(np.inf), np.float32(1.0))
    return made.view(_SearchWeights)


def search_area(
    weights: NDArray[np.float32], start: tuple[int, int], goal: tuple[int, int]
) -> NDArray[np.int32] | None:
    """pyastar2d's path (box cells, start and goal included) on a free area's weights, or None.

    Pure and deterministic: the same weights and cells give the same path in any process.
    """
    path: NDArray[np.int32] | None = pyastar2d.astar_path(weights, start, goal, allow_diagonal=True)
    return path


def search_blocked_bits(bits: NDArray[np.uint8], shape: tuple[int, int]) -> NDArray[np.float32]:
    """:func:`search_weights` of blocked cells packed with ``np.packbits(cells, axis=None)``."""
    cells = np.unpackbits(bits, count=shape[0] * shape[1]).reshape(shape).view(np.bool_)
    return search_weights(cells)


class _SearchWeights(np.ndarray):  # type: ignore[type-arg]
    """The A* weights of a free area (1 on its free cells, inf elsewhere), as ``pyastar2d.astar_path``
    uses them without the costs a search does not need.

    ``flatten()`` is a view: the wrapper flattens the weights before the search, and a copy would
    add 4 bytes a cell to the planning peak. ``min()`` is 1 (the area has a free cell) without
    reading the grid: the wrapper checks it before every search (3 % of a simulated day).
    """

    def flatten(self, order: Any = "C") -> Any:
        return self.ravel(order)

    def min(self, axis: Any = None, *args: Any, **kwargs: Any) -> Any:
        if axis is None and not args and not kwargs:
            return np.float32(1.0)
        return super().min(axis, *args, **kwargs)
