"""Noticing a blocked event loop, and naming the callback and the module that block it.

Everything of an in-process robot (controller, emotion system, modules, API, dashboard) runs
on one asyncio loop: one module callback that calls ``time.sleep``, a synchronous HTTP request
or a serial read stops all of them, with no error anywhere. :class:`LoopWatchdog` runs a
thread that asks the loop for a heartbeat every ``period`` real seconds. When a heartbeat has
waited ``threshold`` seconds the loop is blocked: the watchdog looks at the loop thread's
stack, finds the innermost frame of a component (an object with a ``node``, whose name is the
module's node), and logs one WARNING naming that function, its module and its file and line;
when the loop turns again, one more line says how long it was blocked. :meth:`report` gives
the last block for the robot's status (the dashboard shows it). Time here is real time: a
blocked loop is a real-world stall whatever the robot's clock says.
"""

from __future__ import annotations

import asyncio
import logging
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from types import FrameType
from typing import Any

__all__ = ["Block", "LoopWatchdog"]

log = logging.getLogger(__name__)

FIX = (
    "never block in a callback or goal (no time.sleep, synchronous requests, serial reads or long "
    "computations on the loop): await ctx.sleep(...), or run the blocking call with "
    "await asyncio.to_thread(call, ...); see docs/modules.md, 'Blocking work'"
)


@dataclass
class Block:
    """One time the loop was blocked: by what, for how long, and whether it still is."""

    callback: str
    module: str | None
    where: str
    started: float
    seconds: float = 0.0
    ongoing: bool = True

    def describe(self) -> str:
        module = f"module {self.module}" if self.module else "no module (the robot's own code)"
        return f"{self.callback} ({module}, {self.where})"

    def as_json(self, now: float) -> dict[str, Any]:
        return {
            "callback": self.callback,
            "module": self.module,
            "where": self.where,
            "seconds": round(self.seconds, 1),
            "ongoing": self.ongoing,
            "seconds_ago": round(max(0.0, now - self.started - self.seconds), 1),
            "fix": FIX,
        }


class LoopWatchdog:
    """Watches ``loop`` from a thread of its own; :meth:`start` on the loop's thread, :meth:`stop` when done."""

    def __init__(
        self,
        loop: asyncio.AbstractEventLoop,
        *,
        threshold: float = 2.0,
        period: float = 0.25,
        now: Callable[[], float] = time.monotonic,
    ) -> None:
        self.loop = loop
        self.threshold = threshold
        self.period = period
        self._now = now
        self._asked: float | None = None  # when the pending heartbeat was asked for
        self._loop_thread = 0
        self._stopped = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self.last: Block | None = None
        """The last block seen (None if none)."""
        self.blocks = 0
        """How many times the loop was blocked."""

    def start(self) -> None:
        self._loop_thread = threading.get_ident()
        self._thread = threading.Thread(target=self._watch, name="cyborg loop watchdog", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stopped.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5)

    def report(self) -> dict[str, Any] | None:
        """The last block, for the robot's status; None if the loop was never blocked."""
        with self._lock:
            return None if self.last is None else self.last.as_json(self._now())

    # --- the watching thread ----------------------------------------------------------------

    def _watch(self) -> None:
        while not self._stopped.wait(self.period):
            with self._lock:
                asked = self._asked
                if asked is None:
                    self._asked = self._now()
                    try:
                        self.loop.call_soon_threadsafe(self._beat)
                    except RuntimeError:  # the loop is closed
                        return
                    continue
                waited = self._now() - asked
                if waited < self.threshold or (self.last is not None and self.last.ongoing):
                    continue
                block = self._culprit(asked)
                self.last = block
                self.blocks += 1
            log.warning(
                "the robot is blocked: %s has held its event loop for over %.1f s, so the controller, the "
                "other modules and the dashboard wait; fix: %s",
                block.describe(),
                waited,
                FIX,
            )

    def _beat(self) -> None:
        """On the loop: the heartbeat got through."""
        with self._lock:
            asked, self._asked = self._asked, None
            block = self.last if self.last is not None and self.last.ongoing else None
            if block is None or asked is None:
                return
            block.ongoing = False
            block.seconds = self._now() - asked
        log.warning(
            "the robot's event loop turns again after %.1f s blocked by %s", block.seconds, block.describe()
        )

    def _culprit(self, since: float) -> Block:
        frame = sys._current_frames().get(self._loop_thread)
        innermost: FrameType | None = None
        while frame is not None:
            if innermost is None and not _is_library(frame):
                innermost = frame
            module = _module_of(frame)
            if module is not None:
                return Block(_name(frame), module, _where(frame), since)
            frame = frame.f_back
        if innermost is None:
            return Block("(unknown)", None, "?", since)
        return Block(_name(innermost), None, _where(innermost), since)


def _module_of(frame: FrameType) -> str | None:
    """The node name of the component whose method ``frame`` runs, if it is one."""
    owner = frame.f_locals.get("self")
    node = getattr(owner, "node", None) if owner is not None else None
    name = getattr(node, "name", None)
    return name if isinstance(name, str) else None


def _name(frame: FrameType) -> str:
    return getattr(frame.f_code, "co_qualname", frame.f_code.co_name)


def _where(frame: FrameType) -> str:
    return f"{frame.f_code.co_filename}:{frame.f_lineno}"


def _is_library(frame: FrameType) -> bool:
    path = frame.f_code.co_filename
    return (path.startswith(sys.prefix) and "site-packages" not in path) or "/asyncio/" in path
