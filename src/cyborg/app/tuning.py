"""Garbage collection for a robot that runs for hours: what exists once it is built stays out of
the collector's way.

Python's cyclic garbage collector now and then walks every container object it tracks. A robot of
5,000 states holds millions of them (the state machine, its specification, the modules, the map),
so such a full collection took 23-195 ms, on the controller's own event loop, in the middle of a
handover. Everything made while building lives as long as the robot, so :func:`freeze_built`
moves it out of the collector's generations (``gc.freeze``): a collection then walks only what the
run made since. :func:`thaw` hands it back when the robot closes, so a process that builds many
robots (the tests) still frees the cycles of closed ones.

The simulated base's route search allocates some 48 MB of arrays for the campus map (A* weights,
costs and parents) and frees them after. glibc handed those blocks back to the kernel each time,
so each search page-faulted them in afresh: ~4,700 faults and 11 ms of system time a route, a third
of the planning time. :func:`freeze_built` also asks glibc (``mallopt``) to keep blocks under
64 MB in its heap and to return freed memory only beyond 128 MB: the peak is the same, what the
process holds between searches stays near it.
"""

from __future__ import annotations

import ctypes
import gc
import logging
import sys

__all__ = ["freeze_built", "keep_freed_blocks", "thaw"]

log = logging.getLogger(__name__)

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 64 * 2**20
"""Blocks below this come from glibc's heap (reused), not fresh kernel pages."""
TRIM_THRESHOLD = 128 * 2**20
"""Free memory at the top of glibc's heap it keeps instead of returning it to the kernel."""
_tuned = False


def freeze_built() -> None:
    """Keep every object that exists now out of later garbage collections (call once the robot is
    built), and let big freed blocks be reused (:func:`keep_freed_blocks`)."""
    gc.freeze()
    keep_freed_blocks()


def keep_freed_blocks() -> None:
    """Ask glibc to reuse freed blocks of up to :data:`MMAP_THRESHOLD` (once a process; nothing
    elsewhere than Linux with glibc)."""
    global _tuned
    if _tuned or not sys.platform.startswith("linux"):
        return
    _tuned = True
    try:
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # another C library (musl): it keeps its own ways
        return
    if not (mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) and mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)):
        log.debug("mallopt refused the thresholds; freed blocks go back to the kernel as before")


def thaw() -> None:
    """Let the garbage collector see the frozen objects again (call when the robot closes)."""
    gc.unfreeze()
