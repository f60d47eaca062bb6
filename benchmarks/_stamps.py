"""Shared by the ROS 1 and ROS 2 handover benchmarks: the stamps their servers report, and a wait."""

from __future__ import annotations

import queue
import time
from collections.abc import Callable
from typing import Any


class StampQueue:
    """Stamps reported by the servers as "EVENT STAMP" strings, kept as (event, stamp) in arrival
    order; a subclass subscribes :meth:`_on` to the servers' topic."""

    def __init__(self) -> None:
        self.items: queue.Queue[tuple[str, float]] = queue.Queue()

    def _on(self, message: Any) -> None:
        event, _, stamp = str(message.data).partition(" ")
        self.items.put((event, float(stamp)))

    def next(self, event: str, timeout: float = 10.0) -> float:
        deadline = time.monotonic() + timeout
        while True:
            got, stamp = self.items.get(timeout=max(0.0, deadline - time.monotonic()))
            if got == event:
                return stamp

    def drain(self) -> None:
        while not self.items.empty():
            self.items.get_nowait()


def wait_until(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise SystemExit(f"timed out waiting for {what}")
        time.sleep(0.01)
