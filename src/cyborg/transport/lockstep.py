"""Lockstep time: a node's side of virtual time shared by a graph of processes.

In one process virtual time jumps to the next timer whenever the loop has nothing to do
(:class:`~cyborg.transport.clock.VirtualClock`). Over ROS every process has its own loop, so a
jump is only safe once *every* process has nothing to do at the current time and no message is
on its way. A :class:`LockstepClock` does not jump by itself: when its loop would wait, it tells
the time server (:mod:`cyborg.run.lockstep`) that it is idle, when its next timer is due, how
many messages it holds for the next delta cycle and what its transport sent and received since
it last said (the :class:`~cyborg.transport.ledger.Ledger`); then it waits for I/O.

Messages that arrive are held (:meth:`LockstepClock.deliver`) and taken at the next grant, in
a fixed order: the messages of one instant are taken in delta cycles, a hop at a time, so that
what several senders send in one instant is taken in the same order in every run. The server
grants the same time again (a delta cycle) while any node holds messages, else the earliest
next timer; a grant goes only to the nodes that have something to do, and every node reads the
granted time from a small shared file (:class:`SharedTime`) when it wakes.

The wire protocol is JSON lines over a TCP connection to the server: ``{"hello": NAME, "nodes":
[the graph's nodes of the process]}``, then
reports ``{"gen", "next", "pending", "sent", "recv", "listen", "settle"}`` (counts since the last
report; ``next`` the next timer in integer nanoseconds of virtual time, or null; ``settle`` true
while work waits for the instant to settle, :meth:`Clock.when_settled`; ``graph`` the graph's node
names when they changed, from the node that looks, :meth:`LockstepClock.watch_graph`;
``{"gen", "busy": true}``
while the node holds the time, :meth:`Clock.hold`); the server answers ``{"start": true,
"time_file": PATH}`` once every node has said hello, then grants ``{"gen", "t"}``, and
``{"foreign": [NAME, ...]}`` when the nodes on the graph that are not in the lockstep change.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import mmap
import os
import selectors
import socket
import struct
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from datetime import datetime
from typing import Any

from cyborg.errors import CyborgError
from cyborg.transport.clock import DEFAULT_VIRTUAL_START, NS, DelegatingSelector, VirtualClock, on_grid
from cyborg.transport.ledger import Ledger

__all__ = ["LockstepClock", "SharedTime"]

log = logging.getLogger(__name__)

LARGE_TIME_NS = 2**22 * NS
GRAPH_LOOK = 2.0  # real seconds between looks at the graph's node names (the clock owner's)
CONNECT_TIMEOUT = 30.0  # real seconds a node tries to reach the time server
START_TIMEOUT = 180.0  # real seconds a node waits for every other node to say hello


class SharedTime:
    """The granted time in a small shared file: the server writes it, every node reads it.

    Layout: four little-endian int64: a sequence number (odd while a write is under way), the
    grant's generation, its time in nanoseconds, and the sequence number again.
    """

    SIZE = 32

    def __init__(self, path: str, memory: mmap.mmap) -> None:
        self.path = path
        self._memory = memory

    @classmethod
    def create(cls, folder: str) -> SharedTime:
        handle, path = tempfile.mkstemp(prefix="cyborg-lockstep-", dir=folder)
        os.write(handle, bytes(cls.SIZE))
        memory = mmap.mmap(handle, cls.SIZE)
        os.close(handle)
        return cls(path, memory)

    @classmethod
    def open(cls, path: str) -> SharedTime:
        with open(path, "r+b") as file:
            return cls(path, mmap.mmap(file.fileno(), cls.SIZE))

    def write(self, gen: int, t_ns: int) -> None:
        sequence = struct.unpack_from("<q", self._memory, 0)[0] + 1
        struct.pack_into("<q", self._memory, 0, sequence)
        struct.pack_into("<qqq", self._memory, 8, gen, t_ns, sequence + 1)
        struct.pack_into("<q", self._memory, 0, sequence + 1)

    def read(self) -> tuple[int, int]:
        while True:
            first, gen, t_ns, last = struct.unpack_from("<qqqq", self._memory, 0)
            if first == last and not first % 2:
                return gen, t_ns

    def close(self) -> None:
        self._memory.close()


def _nothing() -> None:
    """What wakes a loop to report a message that arrived."""


class _Link:
    """The connection to the time server: send reports, take grants (on the loop's thread)."""

    def __init__(self, address: str, name: str, nodes: Sequence[str] = ()) -> None:
        host, _, port = address.rpartition(":")
        try:
            self.sock = socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT)
        except (OSError, ValueError) as exc:
            raise CyborgError(
                f"cannot reach the lockstep time server at {address!r} ({exc}); fix: start the node "
                "with `cyborg launch --speed max` (or `cyborg sim --ros --speed max`), which runs it"
            ) from None
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._buffer = b""
        self.send({"hello": name, "nodes": list(nodes)})

    def send(self, message: Mapping[str, Any]) -> None:
        self.sock.sendall(json.dumps(message, separators=(",", ":")).encode() + b"\n")

    def wait_for_start(self) -> str:
        """Wait for the start; return the path of the file that holds the granted time."""
        self.sock.settimeout(START_TIMEOUT)
        try:
            for message in self._read():
                if message.get("start"):
                    return str(message["time_file"])
        except TimeoutError:
            pass
        raise CyborgError(
            f"the lockstep time server did not start the time within {START_TIMEOUT:.0f} s "
            "(it starts once every node of the launch has joined); fix: see the launch's output"
        )

    def _read(self) -> Any:
        while True:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise CyborgError("the lockstep time server went away: the launch has stopped")
            self._buffer += chunk
            while b"\n" in self._buffer:
                line, self._buffer = self._buffer.split(b"\n", 1)
                yield json.loads(line)

    def take_grants(self) -> list[dict[str, Any]]:
        """Every grant waiting on the socket now (the socket is non-blocking)."""
        grants: list[dict[str, Any]] = []
        while True:
            try:
                chunk = self.sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                break
            if not chunk:
                raise CyborgError("the lockstep time server went away: the launch has stopped")
            self._buffer += chunk
        while b"\n" in self._buffer:
            line, self._buffer = self._buffer.split(b"\n", 1)
            grants.append(json.loads(line))
        return grants

    def close(self) -> None:
        self.sock.close()


class _LockstepSelector(DelegatingSelector):
    """Runs what is due now; when the loop would wait, reports idle and waits for I/O or a grant."""

    def __init__(self, clock: LockstepClock) -> None:
        super().__init__()
        self._clock = clock
        self._link_key: selectors.SelectorKey | None = None

    def watch(self, link: _Link) -> None:
        link.sock.setblocking(False)
        self._link_key = self._inner.register(link.sock, selectors.EVENT_READ, None)

    def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
        clock = self._clock
        if timeout is None or timeout > 0:
            clock._report_idle(None if timeout is None else clock._virtual_elapsed + timeout)
            timeout = None if clock._link is not None else timeout
        ready = self._inner.select(timeout)
        if self._link_key is None:
            return ready
        events = [(key, mask) for key, mask in ready if key is not self._link_key]
        clock._take_grants(len(events) != len(ready))
        return events


class _LockstepLoop(asyncio.SelectorEventLoop):
    def __init__(self, clock: LockstepClock) -> None:
        self._lockstep_clock = clock
        super().__init__(selector=_LockstepSelector(clock))
        self._clock_resolution = 1e-9

    def time(self) -> float:
        return self._lockstep_clock._virtual_elapsed

    def call_at(  # type: ignore[override]
        self, when: float, callback: Callable[..., object], *args: Any, context: Any = None
    ) -> asyncio.TimerHandle:
        return super().call_at(
            on_grid(when, self._lockstep_clock._virtual_elapsed), callback, *args, context=context
        )


class LockstepClock(VirtualClock):
    """Virtual time granted by the launch's time server (see the module doc).

    Until :meth:`join` it is a clock standing at ``start``. ``on_advance`` callbacks run on the
    loop after each grant that moved the time (the ``/clock`` publisher's cue).
    """

    def __init__(self, address: str, start: datetime | float = DEFAULT_VIRTUAL_START) -> None:
        super().__init__(start)
        self.address = address
        self.ledger: Ledger = Ledger()
        self._link: _Link | None = None
        self._shared: SharedTime | None = None
        self._gen = 0
        self._reported: tuple[int, int | None, int, bool] | None = None
        self._time_ns = 0
        self._holds = 0
        self.on_advance: list[Callable[[], object]] = []
        self.foreign: tuple[str, ...] = ()
        """Nodes on the graph that are not in the lockstep (the server says which)."""
        self.on_foreign: list[Callable[[tuple[str, ...]], object]] = []
        self._graph: tuple[str, ...] | None = None  # node names seen, not yet reported
        self._graph_stop = threading.Event()

    def deliver(
        self,
        channel: str,
        sender: str,
        callback: Callable[..., object] | None,
        *args: Any,
        counted: Sequence[str] = (),
    ) -> None:
        """As :meth:`VirtualClock.deliver`, from any thread; the cycle starts with the server's
        next grant. The channels in ``counted`` are counted received at once: the server grants
        the cycle once nothing more is on its way."""
        super().deliver(channel, sender, callback, *args)
        for leg in counted:
            self.ledger.received(leg)
        loop = self.loop
        if not loop.is_closed():
            loop.call_soon_threadsafe(_nothing)  # wakes the loop, which reports the arrival

    def watch_graph(self, names: Callable[[], Iterable[str]]) -> None:
        """Look at the graph's node names every GRAPH_LOOK real seconds (on a thread of its own)
        and report them: the server names the nodes that are not in the lockstep and gives them
        a quiet window of real time before each new time. One node of a launch does this."""

        def look() -> None:
            seen: tuple[str, ...] | None = None
            while not self._graph_stop.wait(0 if seen is None else GRAPH_LOOK):
                try:
                    now = tuple(sorted({name.lstrip("/") for name in names()}))
                except Exception as exc:  # a master that does not answer: the next look
                    log.debug("lockstep: could not list the graph's nodes (%s)", exc)
                    continue
                if now != seen:
                    seen = self._graph = now
                    loop = self.loop
                    if not loop.is_closed():
                        loop.call_soon_threadsafe(_nothing)  # wakes the loop, which reports them

        threading.Thread(target=look, name="lockstep graph", daemon=True).start()

    @property
    def is_lockstep(self) -> bool:
        return True

    @property
    def delivers_in_deltas(self) -> bool:
        return True

    def _make_loop(self) -> asyncio.AbstractEventLoop:
        return _LockstepLoop(self)

    def _loop_time(self) -> float:
        return self._virtual_elapsed

    monotonic = _loop_time

    def join(self, name: str, nodes: Sequence[str] = ()) -> None:
        """Connect to the time server as ``name`` (whose process runs the graph's ``nodes``) and
        wait until every node of the launch has."""
        link = _Link(self.address, name, nodes)
        self._shared = SharedTime.open(link.wait_for_start())
        self._link = link
        selector = self.loop._selector  # type: ignore[attr-defined]
        selector.watch(link)

    def hold(self) -> contextlib.AbstractContextManager[None]:
        """Keep the time where it is while the block runs (waits for what only real time brings,
        such as a server's first status): the server grants nothing until it ends."""
        return self._hold()

    @contextlib.contextmanager
    def _hold(self) -> Iterator[None]:
        self._holds += 1
        if self._holds == 1 and self._link is not None:
            self._link.send({"gen": self._gen, "busy": True})
            self._reported = None
        try:
            yield
        finally:
            self._holds -= 1

    def _report_idle(self, next_due: float | None) -> None:
        link = self._link
        if link is None or self._holds:
            return
        next_ns = None if next_due is None else max(self._time_ns, round(next_due * NS))
        changes = self.ledger.take_changes()
        with self._inbox_lock:
            state = (self._gen, next_ns, len(self._inbox), bool(self._settling))
        if changes is None and state == self._reported and self._graph is None:
            return
        self._reported = state
        _, _, pending, settle = state
        report: dict[str, Any] = {"gen": self._gen, "next": next_ns, "pending": pending, **(changes or {})}
        if settle:
            report["settle"] = True
        graph, self._graph = self._graph, None
        if graph is not None:
            report["graph"] = list(graph)
        link.send(report)

    def _take_grants(self, granted: bool) -> None:
        """After the loop woke: take the granted time (every node reads it from the shared file;
        only the nodes that have something to do at it get a grant on their socket, which also
        releases the messages they hold)."""
        assert self._link is not None and self._shared is not None
        moved = False
        grants = self._link.take_grants() if granted else []
        for notice in [grant for grant in grants if "foreign" in grant]:
            grants.remove(notice)
            self.foreign = tuple(notice["foreign"])
            for on_foreign in self.on_foreign:
                self.loop.call_soon(on_foreign, self.foreign)
        released = self._release() if grants else 0
        gen, t_ns = self._shared.read()
        for grant in grants:
            gen, t_ns = max(gen, int(grant["gen"])), max(t_ns, int(grant["t"]))
        self._gen = max(self._gen, gen)
        if t_ns > self._time_ns:
            self._time_ns = t_ns
            self._virtual_elapsed = t_ns / NS
            moved = True
            if t_ns > LARGE_TIME_NS:
                # After ~48 days a float's step nears a nanosecond: asyncio must still see a
                # timer due now as due (it takes those before now + its resolution).
                self.loop._clock_resolution = 2 * math.ulp(self._virtual_elapsed)  # type: ignore[attr-defined]
        if moved:
            for callback in self.on_advance:
                self.loop.call_soon(callback)
        elif grants and not released and self._settling:
            self._settle()  # the server grants the instant again once nothing is held anywhere

    @property
    def time_ns(self) -> int:
        """The granted virtual time: integer nanoseconds since ``start``."""
        return self._time_ns

    def close(self) -> None:
        self._graph_stop.set()
        super().close()
        if self._link is not None:
            self._link.close()
            self._link = None
        if self._shared is not None:
            self._shared.close()
            self._shared = None
