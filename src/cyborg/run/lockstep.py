"""The lockstep time server: virtual time for a graph of processes, granted when all are idle.

``cyborg launch --speed max`` and ``cyborg sim --ros --speed max`` (``--ros2`` too) run a
:class:`TimeServer` on a thread of the launch process and start every node with ``--lockstep
HOST:PORT``. Each node's :class:`~cyborg.transport.lockstep.LockstepClock` reports when its loop
has nothing left to do at the current time, with its next timer and the messages its transport
sent and received since (the node side and the wire protocol are described there).

The server starts the time once every node of the launch has joined, and grants the earliest
next timer of all once (1) every node has reported idle since the last grant and (2) the ledger
balances: on every channel the messages received equal those sent times the listeners (one for a
unicast channel). A message on its way, or a node still working, holds the time back; so the
same inputs give the same run however loaded the machine is, and the run is as fast as its work.

What cannot be counted is tolerated, not trusted: a channel that receives more than was sent
(a latched message to a late subscriber, a message from a process outside the lockstep, such as
the command tool) has the surplus written off at once; one that stays short while every node is
idle for ``patience`` real seconds (a message lost, a node outside the lockstep that never
answers) is written off with a warning naming it, and the time goes on. Both are logged, since
they are where a run may stop being reproducible.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import selectors
import socket
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from cyborg.transport.ledger import Channel
from cyborg.transport.lockstep import SharedTime

__all__ = ["TimeServer"]

log = logging.getLogger(__name__)

PATIENCE = 10.0
"""Real seconds a short channel may stay short while every node is idle before it is written off:
beside three CPU hogs a ROS 1 service call to the base took more than 2 s to arrive, and the write-off
moved a state change 40 ms of virtual time."""
FOREIGN_QUIET = 0.1
"""Real seconds without a report before a new time, while nodes outside the lockstep are on the
graph and talking with it: they follow /clock, and may still be answering what they received."""
FOREIGN_TALK = 5.0
"""Real seconds a conversation with the outside counts as going on: since a message came from
outside the lockstep, or a goal, cancel or request went to a server outside it."""
SURPLUS_SETTLE = 0.05  # real seconds without a report before a surplus counts as from outside


_TO_A_SERVER = ("#goal", "#cancel", "#request", "#get_result")


def _infrastructure(name: str, ours: set[str]) -> bool:
    """A node that is part of the launch or of ROS itself, not a module outside the lockstep:
    a launched part, one of its extra nodes (``rosarnl_node_clock``), ROS 1's rosout, a hidden
    node (ROS 2's ``_`` names), or the launch's own helpers (the API, the parameter home)."""
    return (
        name in ours
        or name.startswith("_")
        or name in {"rosout", "cyborg_api", "cyborg_parameters", "cyborg_launch"}
        or any(name.startswith(f"{part}_") for part in ours)
        or name.startswith("cyborg_tool")
    )


@dataclass
class _Participant:
    sock: socket.socket
    name: str = ""
    buffer: bytes = b""
    gen: int = -1  # the grant its last report answered
    busy: bool = False  # it holds the time (LockstepClock.hold)
    pending: int = 0  # messages it holds for the next grant (a delta cycle)
    settle: bool = False  # work waits for this instant to settle (Clock.when_settled)
    nodes: frozenset[str] = frozenset()  # the graph's nodes of its process
    next_ns: int | None = None
    sent: Counter[str] = field(default_factory=Counter)
    received: Counter[str] = field(default_factory=Counter)
    listening: dict[str, tuple[int, Channel]] = field(default_factory=dict)


class TimeServer:
    """Grants virtual time to the nodes named ``expected`` (see the module doc).

    ``on_grant(t_ns)`` is called (on the server's thread) for every grant that moves the time.
    """

    def __init__(
        self,
        expected: set[str],
        *,
        always: set[str] | None = None,
        patience: float = PATIENCE,
        on_grant: Callable[[int], None] | None = None,
    ) -> None:
        self.expected = set(expected)
        self.always = set(always or ())
        """Nodes woken by every grant that moves the time (the ``/clock`` publisher)."""
        self._shared = SharedTime.create(tempfile.gettempdir())
        self.patience = patience
        self.on_grant = on_grant
        self.time_ns = 0
        self.gen = 0
        self.grants = 0
        self.woken: Counter[str] = Counter()
        """Grants each node was woken by (it had a timer due or messages to take)."""
        self.deltas = 0
        self.started = False
        self.foreign: tuple[str, ...] = ()
        """Nodes on the graph that do not take part in the lockstep (a plain rospy/rclpy node)."""
        self.foreign_seen: set[str] = set()
        self._outside_until = 0.0  # a conversation with the outside goes on until then (monotonic)
        self.written_off: Counter[str] = Counter()
        """Messages written off per channel (short channels; surpluses are not counted here)."""
        self._offset: Counter[str] = Counter()
        self._sent: Counter[str] = Counter()  # over the nodes now taking part
        self._received: Counter[str] = Counter()
        self._listeners: dict[str, tuple[int, Channel]] = {}
        self._balance: dict[str, int] = {}  # the channels that do not balance, and by how much
        self._short_since: float | None = None
        self._last_report = 0.0
        self._listener = socket.create_server(("127.0.0.1", 0))
        self._selector = selectors.DefaultSelector()
        self._selector.register(self._listener, selectors.EVENT_READ, None)
        self._participants: dict[socket.socket, _Participant] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="lockstep time server", daemon=True)

    @property
    def address(self) -> str:
        host, port = self._listener.getsockname()[:2]
        return f"{host}:{port}"

    def start(self) -> TimeServer:
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        for sock in list(self._participants):
            sock.close()
        self._listener.close()
        self._selector.close()
        self._shared.close()
        with contextlib.suppress(OSError):
            os.unlink(self._shared.path)

    # --- the server's thread -----------------------------------------------------------------

    def _serve(self) -> None:
        while not self._stop.is_set():
            for key, _ in self._selector.select(timeout=0.01):
                if key.fileobj is self._listener:
                    sock, _ = self._listener.accept()
                    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                    sock.setblocking(False)
                    self._participants[sock] = _Participant(sock)
                    self._selector.register(sock, selectors.EVENT_READ, None)
                else:
                    self._read(key.fileobj)  # type: ignore[arg-type]
            try:
                self._advance()
            except Exception:
                log.exception("lockstep time server: could not advance the time; it tries again")

    def _read(self, sock: socket.socket) -> None:
        participant = self._participants[sock]
        try:
            chunk = sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            chunk = b""
        if not chunk:
            self._leave(participant)
            return
        participant.buffer += chunk
        while b"\n" in participant.buffer:
            line, participant.buffer = participant.buffer.split(b"\n", 1)
            self._take(participant, json.loads(line))

    def _take(self, participant: _Participant, message: dict[str, Any]) -> None:
        if "hello" in message:
            participant.name = str(message["hello"])
            participant.nodes = frozenset(str(n).lstrip("/") for n in message.get("nodes", ()))
            if self.started:  # a node started again: it joins at the current time
                participant.gen = -1
                self._send(participant, {"start": True, "time_file": self._shared.path})
                self._send(participant, {"gen": self.gen, "t": self.time_ns})
                if self.foreign:  # named before it joined
                    self._send(participant, {"foreign": list(self.foreign)})
                self._rebase(f"{participant.name} joined")
            return
        self._last_report = time.monotonic()
        # A report sent before the node saw the latest grant (which did not need it) is not older news.
        participant.gen = max(participant.gen, int(message["gen"]))
        participant.busy = bool(message.get("busy"))
        if participant.busy:
            return
        participant.pending = int(message.get("pending", 0))
        participant.settle = bool(message.get("settle"))
        if "graph" in message:
            self._graph_seen(message["graph"])
        participant.next_ns = None if message.get("next") is None else int(message["next"])
        touched: set[str] = set()
        for channel, count in message.get("sent", {}).items():
            participant.sent[channel] += count
            self._sent[channel] += count
            touched.add(channel)
            if count > 0 and channel.endswith(_TO_A_SERVER) and not self._listeners.get(channel, (0,))[0]:
                self._outside_until = time.monotonic() + FOREIGN_TALK  # to a server outside the lockstep
        for channel, count in message.get("recv", {}).items():
            participant.received[channel] += count
            self._received[channel] += count
            touched.add(channel)
        for channel, (count, kind) in message.get("listen", {}).items():
            before, _ = participant.listening.get(channel, (0, Channel(kind)))
            participant.listening[channel] = (int(count), Channel(kind))
            total, _ = self._listeners.get(channel, (0, Channel(kind)))
            self._listeners[channel] = (total + int(count) - before, Channel(kind))
            touched.add(channel)
        for channel in touched:
            self._recount(channel)

    def _graph_seen(self, names: list[str]) -> None:
        ours = {p.name for p in self._participants.values() if p.name} | self.expected
        ours.update(*(p.nodes for p in self._participants.values()))
        foreign = tuple(sorted(name for name in names if not _infrastructure(name, ours)))
        if foreign == self.foreign:
            return
        self.foreign = foreign
        self.foreign_seen.update(foreign)
        if foreign:
            log.warning(
                "lockstep: not lockstepped: %s (on the graph, not taking part): while they talk with the "
                "robot, the time waits %.1f s of quiet real time before each new time; a module built "
                "on cyborg.modules takes part when `cyborg launch` runs it (docs/lockstep.md)",
                ", ".join(foreign),
                FOREIGN_QUIET,
            )
        for p in self._participants.values():
            if p.name:
                self._send(p, {"foreign": list(foreign)})

    def _leave(self, participant: _Participant) -> None:
        self._selector.unregister(participant.sock)
        participant.sock.close()
        del self._participants[participant.sock]
        for channel, count in participant.sent.items():
            self._sent[channel] -= count
        for channel, count in participant.received.items():
            self._received[channel] -= count
        for channel, (count, kind) in participant.listening.items():
            total, _ = self._listeners.get(channel, (0, kind))
            self._listeners[channel] = (total - count, kind)
        for channel in set(participant.sent) | set(participant.received) | set(participant.listening):
            self._recount(channel)
        if participant.name:
            log.info("lockstep: %s left at %.3f s", participant.name, self.time_ns / 1e9)
            self._rebase(f"{participant.name} left")

    def _send(self, participant: _Participant, message: dict[str, Any]) -> None:
        data = json.dumps(message, separators=(",", ":")).encode() + b"\n"
        try:
            participant.sock.setblocking(True)
            participant.sock.sendall(data)
            participant.sock.setblocking(False)
        except OSError:
            pass  # it left: its socket reads empty next

    def _recount(self, channel: str) -> None:
        """Received minus expected on ``channel``, beyond what was written off, kept up to date."""
        count, kind = self._listeners.get(channel, (0, Channel.BROADCAST))
        sent = self._sent[channel]
        expected = sent * count if kind is Channel.BROADCAST else (sent if count else 0)
        difference = self._received[channel] - expected - self._offset[channel]
        if difference:
            self._balance[channel] = difference
        else:
            self._balance.pop(channel, None)

    def _write_off(self, channel: str, difference: int) -> None:
        self._offset[channel] += difference
        self._recount(channel)

    def _shortfall(self) -> dict[str, int]:
        """Per channel: received minus expected, beyond what was written off (0: balanced)."""
        return dict(self._balance)

    def _who(self, channel: str) -> str:
        """Who sent and who received how many on ``channel``, for a warning."""
        parts = []
        for p in self._participants.values():
            sent, received = p.sent.get(channel, 0), p.received.get(channel, 0)
            listening = p.listening.get(channel, (0, Channel.BROADCAST))[0]
            if sent or received or listening:
                parts.append(f"{p.name}: sent {sent}, received {received} by {listening} listener(s)")
        return ", ".join(parts)

    def _rebase(self, why: str) -> None:
        for channel, difference in self._shortfall().items():
            self._write_off(channel, difference)
            log.debug("lockstep: %s; %s rebased by %d", why, channel, difference)

    def _advance(self) -> None:
        participants = list(self._participants.values())
        names = {p.name for p in participants}
        if not self.started:
            if not self.expected <= names:
                return
            self.started = True
            for p in participants:
                self._send(p, {"start": True, "time_file": self._shared.path})
            return
        if any(p.gen != self.gen or p.busy for p in participants if p.name):
            self._short_since = None
            return
        balance = self._shortfall()
        short = {channel: -d for channel, d in balance.items() if d < 0}
        surplus = {channel: d for channel, d in balance.items() if d > 0}
        if surplus and not short:
            # More arrived than was counted out: from outside the lockstep, or a sender's report
            # still on its way (then it comes within moments and balances).
            if time.monotonic() - self._last_report < SURPLUS_SETTLE:
                self._short_since = None
                return
            self._outside_until = time.monotonic() + FOREIGN_TALK
            for channel, difference in surplus.items():
                self._write_off(channel, difference)
                log.debug("lockstep: %d message(s) on %s from outside the lockstep", difference, channel)
        if short:
            now = time.monotonic()
            if self._short_since is None:
                self._short_since = now
                return
            if now - self._short_since < self.patience:
                return
            for channel, missing in short.items():
                self._write_off(channel, -missing)
                self.written_off[channel] += missing
            log.warning(
                "lockstep: at %.3f s every node was idle for %.1f s while %s had not arrived; "
                "written off (this run may not repeat exactly)",
                self.time_ns / 1e9,
                self.patience,
                "; ".join(f"{n} message(s) on {c} ({self._who(c)})" for c, n in sorted(short.items())),
            )
        self._short_since = None
        holding = any(p.pending for p in participants if p.name)
        now = time.monotonic()
        talking = self.foreign and now < self._outside_until
        if talking and not holding and now - self._last_report < FOREIGN_QUIET:
            return  # a node outside the lockstep may still be answering at this time
        settling = not holding and any(p.settle for p in participants if p.name)
        if holding or settling:
            # A delta cycle: the messages of this instant are taken; once none is held anywhere,
            # the work that waits for the instant to settle runs.
            t_ns = self.time_ns
            self.deltas += 1
        else:
            deadlines = [p.next_ns for p in participants if p.name and p.next_ns is not None]
            if not deadlines:
                return  # nothing is due anywhere: only a message from outside can start something
            t_ns = max(self.time_ns, min(deadlines))
        self.gen += 1
        self.grants += 1
        moved = t_ns > self.time_ns
        self.time_ns = t_ns
        self._shared.write(self.gen, t_ns)  # before any node acts at the new time
        grant = {"gen": self.gen, "t": t_ns}
        for p in participants:
            if not p.name:
                continue
            due = (
                p.pending
                or (settling and p.settle)
                or (p.next_ns is not None and p.next_ns <= t_ns)
                or (moved and p.name in self.always)
            )
            if due:
                self._send(p, grant)
                self.woken[p.name] += 1
            else:  # nothing for it to do: it reads the time from the shared file when it wakes
                p.gen = self.gen
        if moved and self.on_grant is not None:
            self.on_grant(t_ns)
