"""Tasks per module: a module that starts tasks and never ends them is named before it eats the robot.

A plugin that starts an asyncio task per tick or per sentence and never ends it grows the
process by about a megabyte a second, unnoticed until the machine runs out. Every CHECK_PERIOD
seconds (on the robot's clock) :class:`TaskCensus` counts the pending tasks of the loop by the
Python module their coroutine was written in (``badplug.leak``; the robot's own by package,
``cyborg.navigation``), and warns when a module's count reaches TASK_WARNING, then again each
time it doubles: a handful of lines for a leak that runs all day, each naming the module, its
count, its most frequent coroutine and the fix. ``cyborg sim`` and each ``cyborg node`` run one.
"""

from __future__ import annotations

import asyncio
import logging
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from cyborg.transport.clock import Clock, Periodic

__all__ = ["CHECK_PERIOD", "TASK_WARNING", "TaskCensus", "watch_tasks"]

log = logging.getLogger(__name__)

CHECK_PERIOD = 10.0  # clock seconds between two counts
TASK_WARNING = 1_000  # pending tasks of one module that no module of ours comes near


def module_of(task: asyncio.Task[Any]) -> tuple[str, str]:
    """(the Python module ``task``'s coroutine was written in, the coroutine's name)."""
    coro = task.get_coro()
    frame = getattr(coro, "cr_frame", None) or getattr(coro, "gi_frame", None)
    module = frame.f_globals.get("__name__", "") if frame is not None else ""
    module = module or getattr(coro, "__module__", "") or "?"
    parts = module.split(".")
    group = ".".join(parts[:2]) if parts[0] == "cyborg" else module
    return group, getattr(coro, "__qualname__", type(coro).__name__)


@dataclass
class TaskCensus:
    """Counts pending tasks by module and says when a module's count grows past its last warning."""

    threshold: int = TASK_WARNING
    warned_at: dict[str, int] = field(default_factory=dict)  # module -> the count it was last warned at

    def check(self, tasks: Iterable[asyncio.Task[Any]]) -> list[str]:
        """The warnings for ``tasks`` (the loop's pending ones): one per module past its next mark."""
        by_module: Counter[str] = Counter()
        names: dict[str, Counter[str]] = {}
        for task in tasks:
            if task.done():
                continue
            module, name = module_of(task)
            by_module[module] += 1
            names.setdefault(module, Counter())[name] += 1
        warnings = []
        for module, count in by_module.most_common():
            mark = max(self.threshold, 2 * self.warned_at.get(module, 0))
            if count < mark:
                continue
            self.warned_at[module] = count
            name, most = names[module].most_common(1)[0]
            warnings.append(
                f"module {module} has {count:,} tasks pending ({most:,} of them {name}): it starts "
                "tasks that never end, and the robot grows with each; fix: keep each task and cancel "
                "it in the module's close(), end it when its work is done, or use clock.every() for "
                "periodic work (docs/modules.md)"
            )
        return warnings


def watch_tasks(clock: Clock, census: TaskCensus | None = None, *, period: float = CHECK_PERIOD) -> Periodic:
    """Count the tasks of ``clock``'s loop every ``period`` seconds and log what :class:`TaskCensus` says."""
    census = census or TaskCensus()

    def tick() -> None:
        for warning in census.check(asyncio.all_tasks(clock.loop)):
            log.warning(warning)

    return clock.every(period, tick, name="counting tasks per module", logger=log)
