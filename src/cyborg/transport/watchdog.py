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

The controller's handover deadlines are kept through a block. Given ``deadline`` (when the
controller's current wait on a module ends, on the loop's time line) and ``stoppable`` (the
module nodes it may stop), the watchdog checks the loop at that deadline (plus :data:`GRACE`):
if a stoppable module's callback or goal holds the loop then, it raises :class:`~cyborg.errors.ModuleBlockedError`
inside that call (a signal to the loop's thread, which must be the main thread: the blocking
``time.sleep``, socket or serial read returns at once), the module's call ends as a failure
(a goal ends ABORTED), and the loop goes on to the handover, late by about a second instead
of by the whole block. The handler checks on the loop's own thread that the very
call the watchdog found is still running, so nothing else is ever interrupted.
"""

from __future__ import annotations

import asyncio
import logging
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from types import FrameType
from typing import Any

from cyborg.errors import ModuleBlockedError

__all__ = ["GRACE", "Block", "LoopWatchdog"]

log = logging.getLogger(__name__)

STOP_SIGNAL = signal.SIGUSR2
"""Sent to the loop's (main) thread to stop a module's call that blocks it past a deadline."""
MIN_BLOCK = 0.05
"""Real seconds the loop must have been held before a deadline may stop the call that holds it."""
GRACE = 1.0
"""Real seconds past the controller's deadline before the call holding the loop is stopped: a
module's short burst of work (matching a sentence against thousands of places) that happens to
straddle a deadline is let finish; a handover is late by about this much at most."""

FIX = (
    "never block in a callback or goal (no time.sleep, synchronous requests, serial reads or long "
    "computations on the loop): await ctx.sleep(...), or run the blocking call with "
    "await asyncio.to_thread(call, ...); a module that cannot help blocking gets a process of its own "
    "under `cyborg launch`; see docs/modules.md, 'Blocking work'"
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
    stopped: bool = False
    """True if the watchdog stopped it (ModuleBlockedError) to keep a handover deadline."""

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
            "stopped": self.stopped,
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
        deadline: Callable[[], float | None] | None = None,
        stoppable: Callable[[str], bool] | None = None,
    ) -> None:
        """``deadline`` and ``stoppable`` (see the module's docstring) must come together, with
        ``now`` on the loop's time line; without them the watchdog only names a block."""
        self.loop = loop
        self.threshold = threshold
        self.period = period
        self._now = now
        self._deadline = deadline
        self._stoppable = stoppable
        self._can_stop = False  # the signal handler is installed (start() on the main thread)
        self._stop_at: tuple[float, FrameType, Block] | None = (
            None  # (heartbeat asked, the call to stop, its block)
        )
        self.stops = 0
        """How many blocking calls were stopped to keep a deadline."""
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
        if (
            self._deadline is not None
            and threading.current_thread() is threading.main_thread()
            and _free_for_us(signal.getsignal(STOP_SIGNAL))
        ):
            signal.signal(STOP_SIGNAL, self._interrupt)
            self._can_stop = True
        self._thread = threading.Thread(target=self._watch, name="cyborg loop watchdog", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stopped.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5)
        if self._can_stop and threading.current_thread() is threading.main_thread():
            self._can_stop = False
            if signal.getsignal(STOP_SIGNAL) == self._interrupt:  # (a later watchdog may have it now)
                # SIG_DFL would end the process on a signal still on its way from a thread not yet gone.
                alive = self._thread is not None and self._thread.is_alive()
                signal.signal(STOP_SIGNAL, signal.SIG_IGN if alive else signal.SIG_DFL)

    def report(self) -> dict[str, Any] | None:
        """The last block, for the robot's status; None if the loop was never blocked."""
        with self._lock:
            return None if self.last is None else self.last.as_json(self._now())

    # --- the watching thread ----------------------------------------------------------------

    def _next_check(self) -> float:
        """Real seconds until the next look: the period, or sooner to be there at a deadline."""
        due = self._deadline() if self._can_stop and self._deadline is not None else None
        if due is None:
            return self.period
        until = due + GRACE - self._now()
        return min(self.period, until + 0.01 if until > 0 else 0.05)

    def _watch(self) -> None:
        while not self._stopped.wait(self._next_check()):
            with self._lock:
                asked = self._asked
                if asked is None:
                    self._asked = self._now()
                    try:
                        self.loop.call_soon_threadsafe(self._beat)
                    except RuntimeError:  # the loop is closed
                        return
                    continue
                now = self._now()
                waited = now - asked
                if self._past_deadline(now) and waited >= MIN_BLOCK and self._stop_culprit(asked):
                    continue
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

    def _past_deadline(self, now: float) -> bool:
        if not self._can_stop or self._deadline is None or self._stop_at is not None:
            return False
        due = self._deadline()
        return due is not None and now >= due + GRACE

    def _stop_culprit(self, asked: float) -> bool:
        """(Under the lock.) Stop the module call that holds the loop past a deadline; True if sent."""
        found = self._culprit_frame()
        if found is None or self._stoppable is None:
            return False
        frame, module = found
        if not self._stoppable(module):
            return False
        block = self.last if self.last is not None and self.last.ongoing else self._culprit(asked)
        if block is not self.last:
            self.last = block
            self.blocks += 1
        self._stop_at = (asked, frame, block)
        log.warning(
            "the robot is blocked: %s holds its event loop past the controller's handover deadline; "
            "stopping that call (ModuleBlockedError) so the handover goes on; fix: %s",
            block.describe(),
            FIX,
        )
        signal.pthread_kill(self._loop_thread, STOP_SIGNAL)
        return True

    def _interrupt(self, signum: int, frame: FrameType | None) -> None:
        """On the loop's thread, between two bytecodes of whatever runs: raise in the call to stop,
        if it is still running (the loop did not turn, and its frame is on this stack)."""
        target, self._stop_at = self._stop_at, None
        if target is None or self._asked != target[0]:
            return
        while frame is not None:
            if frame is target[1]:
                target[2].stopped = True
                self.stops += 1
                raise ModuleBlockedError(
                    f"{_name(frame)} held the robot's event loop past the controller's handover deadline, "
                    f"so the loop watchdog stopped it; fix: {FIX}"
                )
            frame = frame.f_back

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
            "the robot's event loop turns again after %.1f s blocked by %s%s",
            block.seconds,
            block.describe(),
            "; the watchdog stopped that call to keep the controller's handover deadline"
            if block.stopped
            else "",
        )

    def _culprit_frame(self) -> tuple[FrameType, str] | None:
        """The frame of the module's code that runs on the loop now, and that module's node name."""
        frame = sys._current_frames().get(self._loop_thread)
        while frame is not None:
            module = _module_of(frame)
            if module is not None:
                return frame, module
            frame = frame.f_back
        return None

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


def _free_for_us(handler: object) -> bool:
    """True if the stop signal has no handler of anyone else's: the default, ignored, or the handler
    of an earlier watchdog of this process (a robot that was never closed)."""
    if handler in (signal.SIG_DFL, signal.SIG_IGN):
        return True
    return isinstance(getattr(handler, "__self__", None), LoopWatchdog)


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
