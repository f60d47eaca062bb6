"""What the route-search worker process of :mod:`cyborg.sim.search_ahead` runs.

Its own module so that the worker imports numpy and pyastar2d (through
:mod:`cyborg.sim.grid_search`) and nothing more of the robot: a small process.
"""

from __future__ import annotations

import contextlib
import ctypes
import signal

import numpy as np
from numpy.typing import NDArray

from cyborg.sim.grid_search import search_area, search_blocked_bits

_worker_weights: dict[int, NDArray[np.float32]] = {}
"""In the worker process only: the weights of the free area it searches (one at a time)."""


_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters


def prepare_worker() -> None:
    """Runs in the worker first. glibc gives each block over its mmap threshold (128 KB at first)
    back to the system when freed, so the two grid-sized arrays of every search (31 MB on the
    campus) would be fresh pages each time: 6-8 ms of page faults a search, most of the search.
    Blocks up to 64 MB stay in the heap instead. Elsewhere than glibc nothing changes.
    Ctrl-C is the robot's to handle: the worker ends when the robot closes it (or its pipe)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None)
        libc.mallopt(_M_MMAP_THRESHOLD, 64 << 20)
        libc.mallopt(_M_TRIM_THRESHOLD, 128 << 20)


def search_in_worker(
    area: int,
    blocked: tuple[NDArray[np.uint8], tuple[int, int]] | None,
    start: tuple[int, int],
    goal: tuple[int, int],
) -> NDArray[np.int32] | None:
    """Runs in the worker: the area's blocked cells (as bits) come with its first search; the
    weights made from them are kept."""
    if blocked is not None:
        _worker_weights.clear()
        _worker_weights[area] = search_blocked_bits(*blocked)
    return search_area(_worker_weights[area], start, goal)
