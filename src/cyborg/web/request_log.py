"""What the HTTP server logs about requests that go wrong: one short line each, rate-limited.

aiohttp logs every malformed request (two Host headers, a bad Content-Length, a TLS hello on
the HTTP port) and every body its client abandoned as an ERROR with a full traceback, before
any token check: anyone who can connect could write megabytes of log a second. This logger
takes the place of aiohttp's ``aiohttp.server`` logger for the robot's API: a request that
breaks the protocol, or a client that leaves mid-request, is one line naming the peer and the
problem; at most one such line per period, with a count of those left out. A failure of the
robot's own code still gets its traceback (also rate-limited). Lives in the web layer, used by
:class:`cyborg.web.api.RobotAPI`.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from typing import Any

from aiohttp.http_exceptions import HttpProcessingError

__all__ = ["RequestLog"]

PERIOD = 10.0
"""Seconds between two lines about bad requests (real time: the log's size is a real-world cost)."""

_CLIENT_FAULTS = (HttpProcessingError, ConnectionError, asyncio.TimeoutError, UnicodeError)


class RequestLog:
    """A stand-in for aiohttp's server logger (``debug``, ``warning``, ``exception``) that is quiet."""

    def __init__(self, logger: logging.Logger, *, now: Callable[[], float] = time.monotonic) -> None:
        self.logger = logger
        self._now = now
        self._next = -float("inf")
        self.left_out = 0
        """Bad requests not written since the last line (the next line says how many)."""
        self.seen = 0
        """Bad requests seen in all (the status and the tests read it)."""

    def debug(self, *args: Any, **kwargs: Any) -> None:
        """aiohttp's debug notes (e.g. a non-HTTP first line): counted, never written."""
        if isinstance(kwargs.get("exc_info"), BaseException):
            self.seen += 1

    def warning(self, message: str, *args: Any, **kwargs: Any) -> None:
        self.logger.warning(message, *args, **kwargs)

    def exception(self, message: str, *args: Any, exc_info: Any = True, **kwargs: Any) -> None:
        """A request that failed: one line if the client broke it, the traceback if our code did."""
        self.seen += 1
        now = self._now()
        if now < self._next:
            self.left_out += 1
            return
        self._next = now + PERIOD
        more = f" ({self.left_out} more in the last {PERIOD:.0f} s not shown)" if self.left_out else ""
        self.left_out = 0
        peer = str(args[0]) if args else "a client"
        if isinstance(exc_info, _CLIENT_FAULTS):
            self.logger.warning("bad HTTP request from %s, refused: %s%s", peer, _one_line(exc_info), more)
            return
        self.logger.error("%s%s", message % args if args else message, more, exc_info=exc_info, **kwargs)


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, HttpProcessingError):
        text = f"{exc.code} {exc.message}"
    elif isinstance(exc, ConnectionError):
        text = f"the client left mid-request ({exc})"
    elif isinstance(exc, asyncio.TimeoutError):
        text = "the client took too long"
    else:
        text = str(exc)
    text = " ".join(text.split())
    return text if len(text) <= 200 else text[:197] + "..."
