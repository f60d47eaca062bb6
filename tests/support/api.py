"""The robot's HTTP API on a real socket, in this process: an embedded transport on a real clock."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator, Iterator

from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.web.api import RobotAPI


@contextlib.contextmanager
def real_time() -> Iterator[tuple[RealClock, EmbeddedTransport]]:
    """A real clock and an embedded transport on it, shut down and closed when the block ends."""
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    try:
        yield clock, transport
    finally:
        transport.shutdown()
        clock.close()


@contextlib.asynccontextmanager
async def served(api: RobotAPI, host: str = "127.0.0.1") -> AsyncIterator[str]:
    """``api`` served on a free port of ``host``: its address without the trailing slash, e.g.
    ``http://127.0.0.1:41234``; the API is stopped when the block ends."""
    url = await api.start(host, 0)
    try:
        yield url.rstrip("/")
    finally:
        await api.stop()
