"""Injected time: a real clock and a deterministic virtual clock.

Every component reads time through a :class:`Clock` and schedules work on the
clock's asyncio event loop, so the same code runs in real time on the robot and
in virtual time in tests and scenario scripts (a simulated day in seconds).

The virtual clock owns an event loop whose ``time()`` is virtual: when no
callback is ready the loop jumps straight to the next timer instead of
waiting, so a run is as fast as the work allows and, for the same inputs and
seed, always takes the same path. With a finite ``speed`` the virtual time runs
at a fixed multiple of real time instead (``--speed 10``).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import selectors
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Awaitable, Callable, Coroutine, Mapping, Sequence
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any, TypeVar

from cyborg.errors import CyborgError, InvalidValueError

if TYPE_CHECKING:
    from cyborg.transport.ledger import Ledger

T = TypeVar("T")

log = logging.getLogger(__name__)

DEFAULT_VIRTUAL_START = datetime(2026, 11, 23, 9, 0, tzinfo=UTC)


class Clock(ABC):
    """Time source plus the event loop that all components run on."""

    ledger: Ledger | None = None
    """Where a transport counts what it sends and receives, when the time waits for every
    message to arrive (:class:`~cyborg.transport.lockstep.LockstepClock`); None otherwise."""

    def __init__(self) -> None:
        self._loop: asyncio.AbstractEventLoop | None = None
        self._making_loop = threading.Lock()
        self._on_close: list[Callable[[], object]] = []

    @property
    def loop(self) -> asyncio.AbstractEventLoop:
        """The loop everything of this clock runs on, made by whoever asks first. Over ROS a
        message may arrive on a middleware thread while the node's parts are being built: both ask
        at once, and a second loop would replace the first with the timers already set on it."""
        loop = self._loop
        if loop is None:
            with self._making_loop:
                if self._loop is None:
                    self._loop = self._make_loop()
                loop = self._loop
        return loop

    @abstractmethod
    def _make_loop(self) -> asyncio.AbstractEventLoop: ...

    @abstractmethod
    def now(self) -> float:
        """Wall-clock time in seconds since the Unix epoch (virtual for virtual clocks)."""

    @property
    def is_virtual(self) -> bool:
        return False

    @property
    def is_lockstep(self) -> bool:
        """True if the time is granted by a time server shared with other processes."""
        return False

    @property
    def delivers_in_deltas(self) -> bool:
        """True if messages are taken in delta cycles (:meth:`deliver`): virtual time at
        ``--speed max``, in one process or in lockstep across a graph of them."""
        return False

    def deliver(
        self,
        channel: str,
        sender: str,
        callback: Callable[..., object] | None,
        *args: Any,
        counted: Sequence[str] = (),
    ) -> None:
        """A message on ``channel`` (a topic, or an action's leg such as ``/name#goal``) from
        ``sender`` arrived: run ``callback(*args)`` on the loop in the next delta cycle (only
        when :attr:`delivers_in_deltas`). The messages of one instant are taken a cycle at a
        time, once nothing else is left to do at that instant; those that arrived in one cycle
        in a fixed order (channel, then an action's legs in the order they are sent, sender, then
        arrival), so that what several senders send in one instant is taken in the same order in
        every run, in one process or over ROS.
        ``counted``: the channels whose arrival lockstep time counts with it."""
        raise NotImplementedError(f"{type(self).__name__} takes each message as it comes")

    def hold(self) -> contextlib.AbstractContextManager[None]:
        """Keep the time from moving on while the block waits for something only real time
        brings (a middleware finding a server): it matters to lockstep time only
        (:class:`~cyborg.transport.lockstep.LockstepClock`), which grants no new time meanwhile."""
        return contextlib.nullcontext()

    @property
    def as_fast_as_possible(self) -> bool:
        """True if the clock jumps to the next timer instead of waiting for it (virtual time at
        ``--speed max``): work nobody waits for in real time is then all the run costs."""
        return False

    def monotonic(self) -> float:
        """Seconds on the loop's monotonic time line (use for durations)."""
        return self.loop.time()

    def datetime(self) -> datetime:
        """The current time as an aware UTC datetime."""
        return datetime.fromtimestamp(self.now(), tz=UTC)

    async def sleep(self, seconds: float) -> None:
        await asyncio.sleep(max(0.0, seconds))

    def call_later(self, delay: float, callback: Callable[..., object], *args: Any) -> asyncio.TimerHandle:
        return self.loop.call_later(max(0.0, delay), callback, *args)

    def call_soon(self, callback: Callable[..., object], *args: Any) -> asyncio.Handle:
        return self.loop.call_soon(callback, *args)

    def when_settled(self, callback: Callable[[], object]) -> None:
        """Run ``callback`` on the loop once the current instant has settled: with virtual time
        at ``--speed max`` (in one process or in lockstep), after every message of this instant
        has been taken and before the time moves on; otherwise soon.

        For work that must not depend on the order in which the messages of one instant came
        (the emotion system applies the feedback of one instant in a fixed order): that order
        differs between one process and a graph of them, the settled instant does not.
        """
        self.loop.call_soon(callback)

    def every(
        self,
        seconds: float,
        callback: Callable[[], object],
        *,
        name: str,
        logger: logging.Logger | None = None,
    ) -> Periodic:
        """Run ``callback`` every ``seconds`` (first after ``seconds``) until the handle is cancelled.

        The one way periodic work runs (see :class:`Periodic`): a tick that raises does not stop
        it, and a run of failures is logged once, as ``name`` (what the work is, for the log).
        """
        return Periodic(self, seconds, callback, name=name, logger=logger)

    def run(self, main: Coroutine[Any, Any, T]) -> T:
        """Run ``main`` to completion on this clock's loop."""
        return self.loop.run_until_complete(main)

    def on_close(self, callback: Callable[[], object]) -> None:
        """Run ``callback`` when the clock closes (after its tasks are cancelled): for what lives as
        long as the loop, such as a helper process, when its owner may never be closed itself."""
        self._on_close.append(callback)

    def close(self) -> None:
        """Cancel whatever is still running on the loop, close it, then run the :meth:`on_close` callbacks."""
        loop = self._loop
        if loop is not None and not loop.is_closed():
            pending = [task for task in asyncio.all_tasks(loop) if not task.done()]
            for task in pending:
                task.cancel()
            if pending:
                loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))
            loop.close()
        callbacks, self._on_close = self._on_close, []
        for callback in callbacks:
            try:
                callback()
            except Exception:
                log.exception("closing the clock: %s failed; the others still run", callback)


class Periodic:
    """Work run every ``period`` clock seconds; :meth:`cancel` stops it (made by :meth:`Clock.every`).

    The next tick is scheduled ``period`` after the end of the previous one, whatever that tick
    did: one that raises does not stop the work. Failures come in episodes: the first failing
    tick after a working one (or the start) logs a warning naming the work and the error (with its
    traceback unless it is a :class:`~cyborg.errors.CyborgError`, which names its fix), further
    failures in a row only at DEBUG, and the first tick that works again logs that it recovered.
    """

    def __init__(
        self,
        clock: Clock,
        period: float,
        callback: Callable[[], object],
        *,
        name: str,
        logger: logging.Logger | None = None,
    ) -> None:
        if not (math.isfinite(period) and period > 0):
            raise InvalidValueError(
                f"the period of {name} must be a positive number of seconds, got {period!r}"
            )
        self.clock = clock
        self.period = period
        self.callback = callback
        self.name = name
        self.failures = 0
        """Ticks that failed in a row (0 while the work works)."""
        self.error: str | None = None
        """The error of the first failing tick of the current episode (None while the work works)."""
        self._log = logger or log
        self._cancelled = False
        self._handle: asyncio.TimerHandle | None = clock.call_later(period, self._run)

    @property
    def cancelled(self) -> bool:
        return self._cancelled

    def cancel(self) -> None:
        """Stop the work: no tick runs after this (also when called from the tick itself)."""
        self._cancelled = True
        if self._handle is not None:
            self._handle.cancel()
            self._handle = None

    def _run(self) -> None:
        self._handle = None
        try:
            self.callback()
        except Exception as exc:
            self._failed(exc)
        else:
            if self.failures:
                self._log.warning(
                    "%s recovered: it works again after %d failed tick%s (%s)",
                    self.name,
                    self.failures,
                    "" if self.failures == 1 else "s",
                    self.error,
                )
                self.failures, self.error = 0, None
        finally:
            if not self._cancelled:
                self._handle = self.clock.call_later(self.period, self._run)

    def _failed(self, exc: Exception) -> None:
        self.failures += 1
        if self.failures > 1:
            self._log.debug("%s failed again (%d in a row): %s", self.name, self.failures, exc)
            return
        self.error = f"{type(exc).__name__}: {exc}"
        self._log.warning(
            "%s failed: %s; it runs again every %g s, and says so here once it works again "
            "(until then further failures are not logged)",
            self.name,
            self.error,
            self.period,
            exc_info=None if isinstance(exc, CyborgError) else exc,
        )


class RealClock(Clock):
    """Real time: the loop sleeps for real, ``now()`` is the system clock."""

    def _make_loop(self) -> asyncio.AbstractEventLoop:
        return asyncio.new_event_loop()

    def now(self) -> float:
        return time.time()


NS = 1_000_000_000
"""Nanoseconds in a second: virtual time at ``--speed max`` moves in whole nanoseconds."""
LARGE_TIME = 2.0**22  # seconds (48 days) after which a float's step nears a nanosecond

POLL_INTERVAL = 0.001
"""Real seconds between looks for I/O (sockets, other threads) while virtual time runs as fast as it can."""


class DelegatingSelector(selectors.BaseSelector):
    """A selector that hands its files to an inner one; subclasses decide how ``select`` waits."""

    def __init__(self) -> None:
        self._inner = selectors.DefaultSelector()

    def register(self, fileobj: Any, events: int, data: Any = None) -> selectors.SelectorKey:
        return self._inner.register(fileobj, events, data)

    def unregister(self, fileobj: Any) -> selectors.SelectorKey:
        return self._inner.unregister(fileobj)

    def modify(self, fileobj: Any, events: int, data: Any = None) -> selectors.SelectorKey:
        return self._inner.modify(fileobj, events, data)

    def get_map(self) -> Mapping[Any, selectors.SelectorKey]:
        return self._inner.get_map()

    def close(self) -> None:
        self._inner.close()


class _VirtualTimeSelector(DelegatingSelector):
    """Selector that advances virtual time instead of blocking on timers."""

    def __init__(self, clock: VirtualClock) -> None:
        super().__init__()
        self._clock = clock
        self._polled = -math.inf  # real time of the last look for I/O

    def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
        speed = self._clock.speed
        if speed is not None:
            real_timeout = None if timeout is None else timeout / speed
            before_origin = self._clock._real_origin - time.monotonic()
            if real_timeout and before_origin > 0:  # time stands still until the origin
                real_timeout = None if math.isinf(before_origin) else real_timeout + before_origin
            return self._inner.select(real_timeout)
        if self._clock._settling and (timeout is None or timeout > 0):
            self._clock._settle()  # nothing else is left at this instant
            return []
        if timeout is None:
            # Nothing is scheduled: only I/O or another thread can wake us.
            return self._inner.select(None)
        # Look for I/O at most once a real millisecond: a system call on each of the millions of
        # loop turns of a simulated day cost more than the work they ran.
        now = time.monotonic()
        if now - self._polled >= POLL_INTERVAL:
            self._polled = now
            ready = self._inner.select(0)
            if ready:
                return ready
        if timeout > 0:
            self._clock._advance(timeout)
        return []


_LEG_ORDER = {"goal": 0, "request": 0, "cancel": 1, "response": 1, "accept": 2, "status": 3, "feedback": 4}
"""The legs of one action (or service) that arrive in one delta cycle, in the order they were
sent: a goal before its cancel, the answer before the result (text and result come last)."""
_LEG_ORDER.update(text=5, result=6)


def on_grid(when: float, now: float) -> float:
    """``when`` moved up to the next whole nanosecond (a float's noise below 0.001 ns aside),
    and in any case after ``now`` if ``when`` is.

    Timers of lockstep time fire on this grid (:mod:`cyborg.transport.lockstep`): the time
    jumps from timer to timer through every process's timers, and how a time was reached must
    not change it by a float's last bit, or a comparison such as "10 s in this state" would come
    out differently from one run to the next.
    """
    grid = math.ceil(round(when * NS, 3)) / NS
    if grid <= now < when:  # a wait for a fraction of a nanosecond must still move the time
        grid = max((round(now * NS) + 1) / NS, math.nextafter(now, math.inf))
    return grid


class _VirtualTimeLoop(asyncio.SelectorEventLoop):
    def __init__(self, clock: VirtualClock) -> None:
        self._virtual_clock = clock
        super().__init__(selector=_VirtualTimeSelector(clock))
        self._clock_resolution = 1e-9

    def call_at(  # type: ignore[override]
        self, when: float, callback: Callable[..., object], *args: Any, context: Any = None
    ) -> asyncio.TimerHandle:
        if self._virtual_clock.speed is None:
            when = on_grid(when, self._virtual_clock._virtual_elapsed)
        return super().call_at(when, callback, *args, context=context)

    def time(self) -> float:
        clock = self._virtual_clock
        if clock.speed is None:  # read a few times every loop turn: one call, not two
            return clock._virtual_elapsed
        return clock._loop_time()


class VirtualClock(Clock):
    """Virtual time starting at ``start``.

    ``speed=None`` runs as fast as the work allows (deterministic);
    a number runs that many virtual seconds per real second.

    ``real_origin`` (with a speed only) is the wall-clock time (Unix seconds, as ``time.time()``)
    at which this clock reads ``start``; by default the moment it is made. Processes given the
    same ``start``, ``speed`` and ``real_origin`` read the same virtual time (``cyborg launch
    --speed``). Before its origin the clock stands still at ``start``; ``math.inf`` makes it wait
    for :meth:`anchor`.
    """

    def __init__(
        self,
        start: datetime | float = DEFAULT_VIRTUAL_START,
        speed: float | None = None,
        *,
        real_origin: float | None = None,
    ) -> None:
        super().__init__()
        if speed is not None and speed <= 0:
            raise InvalidValueError(f"speed must be positive or None (as fast as possible), got {speed!r}")
        if speed is None and real_origin is not None:
            raise InvalidValueError(
                "a real-time origin needs a speed: with speed=None the clock does not follow real time"
            )
        self.speed = speed
        self._inbox: list[
            tuple[tuple[str, int, str, int], Callable[..., object] | None, tuple[Any, ...]]
        ] = []
        self._inbox_lock = threading.Lock()
        self._settling: list[Callable[[], object]] = []
        self._arrivals: dict[tuple[str, str], int] = {}
        self._start_epoch = start.timestamp() if isinstance(start, datetime) else float(start)
        self._virtual_elapsed = 0.0
        self._real_origin = time.monotonic()
        if real_origin is not None:
            self.anchor(real_origin)

    def deliver(
        self,
        channel: str,
        sender: str,
        callback: Callable[..., object] | None,
        *args: Any,
        counted: Sequence[str] = (),
    ) -> None:
        base, _, leg = channel.partition("#")
        with self._inbox_lock:
            key = (channel, sender)
            self._arrivals[key] = arrival = self._arrivals.get(key, 0) + 1
            self._inbox.append(((base, _LEG_ORDER.get(leg, 0), sender, arrival), callback, args))

    def _release(self) -> int:
        """Hand the messages that arrived in the last delta cycle to the loop, in their order;
        return how many there were."""
        with self._inbox_lock:
            inbox, self._inbox = self._inbox, []
        inbox.sort(key=lambda item: item[0])
        loop = self.loop
        for _, callback, args in inbox:
            if callback is not None:
                loop.call_soon(callback, *args)
        return len(inbox)

    def when_settled(self, callback: Callable[[], object]) -> None:
        if self.speed is None:
            self._settling.append(callback)
        else:
            self.loop.call_soon(callback)

    def _settle(self) -> None:
        """The instant has settled: run what waited for it (:meth:`Clock.when_settled`)."""
        settling, self._settling = self._settling, []
        for callback in settling:
            self.loop.call_soon(callback)

    def anchor(self, real_origin: float) -> None:
        """Read ``start`` at wall-clock time ``real_origin`` (Unix seconds) and run at ``speed`` from there.

        The origin is kept on the monotonic time line (CLOCK_MONOTONIC: one for every process of
        the machine), converted from the wall clock once, so clock steps later do not move it.
        """
        if self.speed is None:
            raise InvalidValueError(
                "only a clock with a speed follows real time; this one runs as fast as possible"
            )
        if math.isinf(real_origin):
            self._real_origin = math.inf
        else:
            self._real_origin = time.monotonic() + (float(real_origin) - time.time())

    @property
    def real_origin(self) -> float:
        """The wall-clock time (Unix seconds) at which this clock reads ``start`` (speed only)."""
        if math.isinf(self._real_origin):
            return math.inf
        return time.time() - (time.monotonic() - self._real_origin)

    @property
    def is_virtual(self) -> bool:
        return True

    @property
    def as_fast_as_possible(self) -> bool:
        return self.speed is None

    def _make_loop(self) -> asyncio.AbstractEventLoop:
        return _VirtualTimeLoop(self)

    def _loop_time(self) -> float:
        if self.speed is None:
            return self._virtual_elapsed
        return max(0.0, (time.monotonic() - self._real_origin) * self.speed)

    # The loop's time() without going through the loop: read millions of times in a simulated day.
    monotonic = _loop_time

    def _advance(self, seconds: float) -> None:
        # To the next timer, which is on the nanosecond grid (on_grid), as lockstep time is:
        # rounding takes away the float error of elapsed + (when - elapsed).
        target = self._virtual_elapsed + seconds
        moved = round(target * NS) / NS
        self._virtual_elapsed = moved if moved > self._virtual_elapsed else target
        if self._virtual_elapsed > LARGE_TIME and self._loop is not None:
            # After ~48 days a float's step nears a nanosecond: asyncio must still see a timer
            # due now as due (it takes those before now + its resolution).
            self._loop._clock_resolution = 2 * math.ulp(self._virtual_elapsed)  # type: ignore[attr-defined]

    def now(self) -> float:
        return self._start_epoch + self._loop_time()

    @property
    def start_epoch(self) -> float:
        return self._start_epoch


def run_with(clock: Clock, main: Callable[[], Awaitable[T]]) -> T:
    """Run an async function on ``clock``'s loop and return its result."""

    async def _main() -> T:
        return await main()

    return clock.run(_main())
