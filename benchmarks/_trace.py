"""Step stamps for the handover benchmarks' ``--trace``: where a handover's time goes.

Each benchmark process notes ``(step, time.perf_counter())`` when a handover passes one of its
steps (CLOCK_MONOTONIC: one time line for the whole machine) and writes them to
``$BENCH_TRACE/<role>.json`` when it stops. The measuring process then takes, for every
handover, the first stamp of each step between the event's publication and the next goal's
ACTIVE stamp, and prints the medians. Nothing is noted unless ``BENCH_TRACE`` is set.
"""

from __future__ import annotations

import bisect
import functools
import json
import os
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

_MARKS: list[tuple[str, float]] = []


def enabled() -> bool:
    return bool(os.environ.get("BENCH_TRACE"))


def mark(step: str) -> None:
    _MARKS.append((step, time.perf_counter()))  # list.append is atomic: any thread may call it


def wrap(
    owner: Any,
    name: str,
    before: str | None = None,
    after: str | None = None,
    when: Callable[..., bool] | None = None,
) -> None:
    """Note ``before`` / ``after`` around ``owner.name`` (a function or method; a coroutine
    function is noted when it starts and when it returns), if ``when(*args)`` holds."""
    original = getattr(owner, name)
    import inspect

    if inspect.iscoroutinefunction(original):

        @functools.wraps(original)
        async def traced_async(*args: Any, **kwargs: Any) -> Any:
            noted = when is None or when(*args, **kwargs)
            if noted and before:
                mark(before)
            result = await original(*args, **kwargs)
            if noted and after:
                mark(after)
            return result

        setattr(owner, name, traced_async)
        return

    @functools.wraps(original)
    def traced(*args: Any, **kwargs: Any) -> Any:
        noted = when is None or when(*args, **kwargs)
        if noted and before:
            mark(before)
        result = original(*args, **kwargs)
        if noted and after:
            mark(after)
        return result

    setattr(owner, name, traced)


def dump(role: str) -> None:
    directory = os.environ.get("BENCH_TRACE")
    if directory:
        Path(directory, f"{role}.json").write_text(json.dumps(_MARKS))


def load(directory: str) -> dict[str, list[float]]:
    """Every process's stamps, by step, in time order."""
    steps: dict[str, list[float]] = {}
    for path in Path(directory).glob("*.json"):
        for step, stamp in json.loads(path.read_text()):
            steps.setdefault(step, []).append(stamp)
    for stamps in steps.values():
        stamps.sort()
    return steps


def breakdown(
    windows: Sequence[tuple[float, float]], steps: dict[str, list[float]], order: Sequence[str]
) -> list[tuple[str, float, float, int]]:
    """For each step of ``order``: (step, median ms since the window opened, median ms since the
    previous step, handovers in which it was seen); windows are (event published, goal ACTIVE)."""
    rows = []
    previous: list[float | None] = [start for start, _ in windows]
    for step in order:
        stamps = steps.get(step, [])
        since_start: list[float] = []
        since_previous: list[float] = []
        now: list[float | None] = []
        for (start, end), before in zip(windows, previous, strict=True):
            index = bisect.bisect_left(stamps, start)
            if index < len(stamps) and stamps[index] <= end:
                since_start.append((stamps[index] - start) * 1000)
                if before is not None:
                    since_previous.append((stamps[index] - before) * 1000)
                now.append(stamps[index])
            else:
                now.append(before)  # not seen: the next step is timed from the last one seen
        previous = now
        rows.append(
            (
                step,
                statistics.median(since_start) if since_start else float("nan"),
                statistics.median(since_previous) if since_previous else float("nan"),
                len(since_start),
            )
        )
    return rows
