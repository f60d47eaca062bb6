"""How a rospy publisher of a RosTransport process writes: at once when the socket takes it.

Part of the ROS 1 transport (:mod:`cyborg.transport.ros`), installed by :mod:`.patches`. A rospy
publisher made with a ``queue_size`` (ours, and actionlib's goal, cancel, status and result
publishers) hands every message to a writer thread per connection. That costs a thread switch
per message, and the writer waits for the interpreter lock while the publishing thread goes on:
a controller that cancels a goal and then sets up its wait, or sends a goal and then records it,
delays its own message by that much (docs/benchmarks-history.md, handover over ROS 1).

:class:`WriteAtOnceConnection` writes the message in the publishing thread when nothing is
waiting in its queue and the socket takes it without blocking; otherwise (a slow or stuck
subscriber, a full socket buffer, an error) it queues it for the writer thread, as rospy does,
with rospy's bound on the queue. So ``publish`` still never blocks, and the order on each
connection is kept: nothing is written at once while the writer thread has data in hand.
"""

from __future__ import annotations

import select
import socket
import time
from typing import Any

from rospy.impl.tcpros_pubsub import QueuedConnection  # type: ignore[import-not-found]

__all__ = ["WriteAtOnceConnection"]


class _Rest(bytes):
    """The unsent end of a message written in part: it must follow at once, and is never dropped."""


class WriteAtOnceConnection(QueuedConnection):  # type: ignore[misc]
    """rospy's queued connection, writing in the caller's thread when that cannot block."""

    _queue: list[bytes]  # (rospy's, set in its __init__)
    _error: Exception | None

    def __init__(self, connection: Any, queue_size: int) -> None:
        self._writing = False  # the writer thread has taken data from the queue and is writing it
        super().__init__(connection, queue_size)  # (starts the writer thread)

    def write_data(self, data: bytes) -> bool:
        with self._lock:
            if self._error:
                error, self._error = self._error, None
                raise error
            if not self._queue and not self._writing:
                sent = self._send_now(data)
                if sent == len(data):
                    return True
                if sent:
                    self._queue.append(_Rest(data[sent:]))
                    self._cond_data_available.notify()
                    return True
            if self._queue_size > 0 and len(self._queue) >= self._queue_size:
                self._drop_oldest()
            self._queue.append(data)
            self._cond_data_available.notify()
        time.sleep(0)  # as rospy's: let the writer thread run
        return True

    def _send_now(self, data: bytes) -> int:
        """Bytes of ``data`` the socket took without blocking (0 on any trouble: the writer thread
        then meets it, and rospy handles it as before)."""
        connection = self._connection
        sock = getattr(connection, "socket", None)
        if connection.done or not isinstance(sock, socket.socket):
            return 0
        try:
            # rospy gives every socket a timeout (socket.setdefaulttimeout(60)), and Python's send on
            # such a socket first waits up to that long for room, whatever the flags: look first.
            if not select.select([], [sock], [], 0)[1]:
                return 0
            sent = sock.send(data, socket.MSG_DONTWAIT)
        except (OSError, ValueError):
            return 0
        connection.stat_bytes += sent
        if sent == len(data):
            connection.stat_num_msg += 1
        return sent

    def _drop_oldest(self) -> None:
        """rospy's bound on the queue: drop the oldest whole message (never the end of one in part)."""
        for index, data in enumerate(self._queue):
            if not isinstance(data, _Rest):
                del self._queue[index]
                return

    def _run(self) -> None:  # the writer thread: rospy's loop, saying while it writes
        while not self._connection.done:
            with self._lock:
                self._writing = False
                while not self._queue and not self._connection.done:
                    self._cond_data_available.wait()
                queue, self._queue = self._queue, []
                self._writing = bool(queue)
            for data in queue:
                try:
                    self._connection.write_data(data)
                except Exception as error:
                    with self._lock:
                        self._error = error
