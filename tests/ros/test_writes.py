"""A publisher connection writes at once when the socket takes it, never blocks, and keeps order.

:class:`~cyborg.transport.ros.writes.WriteAtOnceConnection` on a real socket pair (no roscore):
what a reader receives is every message, whole and in order, whether it was written at once, in
part, or by the writer thread while the reader was not reading.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator

import pytest

from cyborg.transport.ros.writes import WriteAtOnceConnection


class _Transport:
    """What rospy's TCPROS transport offers a queued connection: a socket and write_data."""

    def __init__(self, sock: socket.socket) -> None:
        self.socket = sock
        self.done = False
        self.stat_bytes = 0
        self.stat_num_msg = 0
        self.writer_threads: set[str] = set()

    def write_data(self, data: bytes) -> bool:
        self.writer_threads.add(threading.current_thread().name)
        self.socket.sendall(data)
        self.stat_bytes += len(data)
        self.stat_num_msg += 1
        return True

    def set_cleanup_callback(self, callback: Callable[[object], None]) -> None:
        self._cleanup = callback

    def close(self) -> None:  # as rospy's: the queued connection hears of it (its thread ends)
        self.done = True
        self._cleanup(self)


@pytest.fixture
def pair() -> Iterator[tuple[socket.socket, socket.socket]]:
    writer, reader = socket.socketpair()
    writer.settimeout(60.0)  # as rospy's sockets: it sets socket.setdefaulttimeout(60)
    writer.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4096)
    reader.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    try:
        yield writer, reader
    finally:
        writer.close()
        reader.close()


def _read(reader: socket.socket, size: int) -> bytes:
    got = b""
    reader.settimeout(10)
    while len(got) < size:
        got += reader.recv(size - len(got))
    return got


def test_a_message_goes_out_in_the_publishing_thread_when_the_socket_takes_it(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    writer, reader = pair
    transport = _Transport(writer)
    connection = WriteAtOnceConnection(transport, 10)
    try:
        connection.write_data(b"cancel goal 1;")
        assert _read(reader, 14) == b"cancel goal 1;"
        assert transport.writer_threads == set()  # the writer thread had nothing to do
        assert transport.stat_num_msg == 1
    finally:
        transport.close()


def test_a_full_socket_never_blocks_the_publisher_and_every_message_arrives_whole_in_order(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    writer, reader = pair
    transport = _Transport(writer)
    connection = WriteAtOnceConnection(transport, 0)  # 0: rospy's unbounded queue
    messages = [f"<message {i:04d} {'x' * 900}>".encode() for i in range(200)]  # far over the buffers
    try:
        publisher = threading.Thread(target=lambda: [connection.write_data(m) for m in messages])
        publisher.start()
        publisher.join(30)  # nobody reads meanwhile: a publish that waits for the reader never ends
        assert not publisher.is_alive(), "a publish waited for the reader"
        expected = b"".join(messages)
        assert _read(reader, len(expected)) == expected
        assert transport.writer_threads, "the writer thread took what the socket could not"
    finally:
        transport.close()


def test_a_bounded_queue_drops_whole_old_messages_never_the_end_of_one_written_in_part(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    writer, reader = pair
    transport = _Transport(writer)
    connection = WriteAtOnceConnection(transport, 2)
    messages = [f"<{i:04d}{'y' * 3000}>".encode() for i in range(40)]
    try:
        for message in messages:
            connection.write_data(message)
        got = b""
        reader.settimeout(10)
        while not got.endswith(messages[-1]):  # the last one is never dropped
            got += reader.recv(65536)
        # What arrived is a run of whole messages: none cut, each kept one in the order sent.
        parts = got.split(b">")[:-1]
        assert got.endswith(b">") and parts
        indexes = [int(part[1:5]) for part in parts]
        assert all(part == messages[i][:-1] for part, i in zip(parts, indexes, strict=True))
        assert indexes == sorted(indexes) and indexes[-1] == 39
        assert len(indexes) < 40  # the bound dropped some
    finally:
        transport.close()
