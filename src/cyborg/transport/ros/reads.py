"""How a RosTransport process reads its subscriptions: on the event loop, not on a thread per connection.

Part of the ROS 1 transport (:mod:`cyborg.transport.ros`), installed by :mod:`.patches`. rospy
reads every subscriber connection on a thread of its own, and our components run on the
clock's event loop: each message woke the reading thread, which woke the loop
(``call_soon_threadsafe``), two wake-ups and a hand-over of the interpreter lock per message.
On a robot that sleeps between events each wake-up of a sleeping thread costs, and a
handover passes four such hops (the event and the result in the controller, the cancel and
the goal in the module; docs/benchmarks-history.md, handover over ROS 1).

So once rospy has connected a subscriber and exchanged the headers, a connection whose every
callback belongs to components of one loop (our subscriptions and actionlib's subscribers
inside our action clients and servers, marked with :data:`LOOP_ATTRIBUTE`) is read by that
loop: the socket is watched with ``add_reader``, read without blocking, its messages
deserialised and handed to rospy's callbacks there, exactly as rospy's thread would (the
connection header on each message, the latched message kept, the statistics counted). The
callbacks still hand our components' work on with ``call_soon``, on a later loop turn, so
nothing runs inside actionlib's locks. rospy's thread waits meanwhile; it takes the
connection back, and handles it as rospy does (a reconnect, an error, the end), when the
loop meets anything but whole messages: end of stream, a socket error, a bad message, a
callback of someone else's (a plain ``rospy.Subscriber`` on the same topic in this process),
or a loop that has stopped. Closing the connection first takes the socket off the loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

import rospy  # type: ignore[import-not-found]
from rospy.impl.tcpros_base import TCPROSTransport  # type: ignore[import-not-found]
from rospy.topics import _SubscriberImpl  # type: ignore[import-not-found]

from cyborg.transport.clock import Clock

__all__ = ["LOOP_ATTRIBUTE", "install", "mark", "read_waiting"]

log = logging.getLogger(__name__)

LOOP_ATTRIBUTE = "_cyborg_loop"
"""Set on an object whose bound methods are rospy subscriber callbacks that may run on this loop."""
CALLBACK_WAIT = 0.5  # seconds a connection made before its subscriber's callback waits for it
DETACH_WAIT = 1.0  # seconds a close from another thread waits for the loop to let go of the socket

_original_receive_loop: Callable[..., None] | None = None
_original_close: Callable[..., None] | None = None


def mark(owner: object, clock: Clock) -> None:
    """Let rospy subscriber callbacks bound to ``owner`` run on ``clock``'s loop, if it runs in real
    time (virtual and lockstep time keep rospy's threads: they count or poll what those deliver)."""
    if not clock.is_virtual:
        setattr(owner, LOOP_ATTRIBUTE, clock.loop)


def install() -> None:
    """Patch rospy's subscriber connections for this process (idempotent)."""
    global _original_receive_loop, _original_close
    if _original_receive_loop is not None:
        return
    _original_receive_loop = TCPROSTransport.receive_loop
    _original_close = TCPROSTransport.close
    TCPROSTransport.receive_loop = _receive_loop
    TCPROSTransport.close = _close


def read_waiting(subscriber: Any) -> None:
    """Deliver now what waits unread on ``subscriber``'s connections that this loop reads (called
    on the loop: after the loop was busy a while, what rospy's threads would have delivered
    meanwhile, such as an action server's status, still counts before a decision is taken)."""
    running = asyncio._get_running_loop()
    for connection in list(getattr(getattr(subscriber, "impl", None), "connections", ())):
        reader: _LoopReader | None = getattr(connection, "_cyborg_reader", None)
        if reader is not None and reader.loop is running:
            reader.read_all()


def _loop_of(msgs_callback: Callable[..., None]) -> asyncio.AbstractEventLoop | None:
    """The one loop every callback of the subscriber behind ``msgs_callback`` belongs to, if any."""
    impl = getattr(msgs_callback, "__self__", None)
    if not isinstance(impl, _SubscriberImpl):
        return None
    loops = {getattr(getattr(cb, "__self__", None), LOOP_ATTRIBUTE, None) for cb, _ in impl.callbacks}
    if len(loops) != 1:
        return None
    loop = loops.pop()
    return None if loop is None or loop.is_closed() else loop


def _receive_loop(connection: Any, msgs_callback: Callable[..., None]) -> None:  # rospy's thread
    assert _original_receive_loop is not None
    loop = _loop_of(msgs_callback)
    impl = getattr(msgs_callback, "__self__", None)
    if loop is None and isinstance(impl, _SubscriberImpl) and not impl.callbacks:
        # rospy connects a new subscriber to the publishers it knows before it adds the callback
        # (a latched message may be read with the header already): wait for the callback a moment
        deadline = time.monotonic() + CALLBACK_WAIT
        while not impl.callbacks and not connection.done and time.monotonic() < deadline:
            time.sleep(0.001)
        loop = _loop_of(msgs_callback)
    if loop is not None:
        reader = connection._cyborg_reader = _LoopReader(connection, msgs_callback, loop)
        try:
            loop.call_soon_threadsafe(reader.attach)
        except RuntimeError:  # the loop closed meanwhile: read here
            connection._cyborg_reader = None
        else:
            reader.given_back.wait()
            if reader.pending:  # for someone else's callback: delivered here, on rospy's thread
                msgs_callback(reader.pending, connection)
    _original_receive_loop(connection, msgs_callback)


def _close(connection: Any) -> None:
    assert _original_close is not None
    reader: _LoopReader | None = getattr(connection, "_cyborg_reader", None)
    if reader is not None:
        reader.detach_from_any_thread()
    _original_close(connection)


class _LoopReader:
    """One subscriber connection, read on ``loop`` until it gives the connection back."""

    def __init__(
        self, connection: Any, msgs_callback: Callable[..., None], loop: asyncio.AbstractEventLoop
    ) -> None:
        self.connection = connection
        self.msgs_callback = msgs_callback
        self.loop = loop
        self.given_back = threading.Event()
        self.pending: list[Any] = []  # read here, to be delivered by rospy's thread
        self._fd: int | None = None
        self._sock: socket.socket | None = None

    def attach(self) -> None:  # loop
        connection = self.connection
        sock = connection.socket
        if connection.done or rospy.is_shutdown() or not isinstance(sock, socket.socket):
            self.give_back()
            return
        self._sock, self._fd = sock, sock.fileno()
        sock.setblocking(False)  # (rospy's thread sets it blocking again when it takes it back)
        self.loop.add_reader(self._fd, self._readable)
        if connection.read_buff.tell() >= 4:  # rospy's thread had read ahead
            self._deliver(b"")

    def _readable(self) -> bool:  # loop; False once nothing more waits (or the connection went back)
        if self._sock is None:
            return False
        try:
            data = self._sock.recv(self.connection.protocol.buff_size)
        except (BlockingIOError, InterruptedError):
            return False
        except Exception:  # an error, or closed under us: rospy's thread meets it again
            self.give_back()
            return False
        if not data:  # end of stream: rospy's thread reads it too and ends the connection
            self.give_back()
            return False
        self._deliver(data)
        return True

    def read_all(self) -> None:  # loop
        """Read and deliver everything the socket holds now."""
        while self._fd is not None and self._readable():
            pass

    def _deliver(self, data: bytes) -> None:  # loop
        connection = self.connection
        try:
            buffer = connection.read_buff
            if data:
                buffer.write(data)
                connection.stat_bytes += len(data)
            messages: list[Any] = []
            if buffer.tell() >= 4:
                connection.protocol.read_messages(buffer, messages, self._sock)
        except Exception:  # a bad message (or the connection closed): as rospy's thread handles it
            log.debug(
                "reading %s on the loop failed; rospy's thread takes it back", connection.name, exc_info=True
            )
            self.give_back()
            return
        if not messages:
            return
        connection.stat_num_msg += len(messages)
        for message in messages:
            message._connection_header = connection.header
        if connection.is_latched:
            connection.latch = messages[-1]
        if connection.done or rospy.is_shutdown():
            self.give_back()
            return
        if _loop_of(self.msgs_callback) is not self.loop:  # someone else's callback joined the topic
            self.pending = messages
            self.give_back()
            return
        self.msgs_callback(messages, connection)

    def give_back(self) -> None:  # loop
        """Stop reading here; rospy's thread takes the connection back."""
        self._remove()
        self.given_back.set()

    def _remove(self) -> None:
        if self._fd is not None:
            fd, self._fd = self._fd, None
            with contextlib.suppress(Exception):  # the loop or the socket already closed
                self.loop.remove_reader(fd)
        if getattr(self.connection, "_cyborg_reader", None) is self:
            self.connection._cyborg_reader = None

    def detach_from_any_thread(self) -> None:
        """Take the socket off the loop before the connection closes it (on the loop: at once;
        from another thread: through the loop, waiting DETACH_WAIT at most)."""
        loop = self.loop
        if asyncio._get_running_loop() is loop or not loop.is_running():
            self.give_back()
            return
        removed = threading.Event()

        def remove() -> None:
            self.give_back()
            removed.set()

        try:
            loop.call_soon_threadsafe(remove)
        except RuntimeError:  # closed meanwhile: its selector is gone with it
            self.given_back.set()
            return
        removed.wait(DETACH_WAIT)
