"""A day of an otherwise idle robot in virtual time: the motivator's acceptance run.

The idle module, two motivational events (music 60 s, a joke 5 s), the emotion
system and the motivator run on a virtual clock; nobody else sends events. The
test (tests/motivator) and the benchmark (benchmarks/bench_idle_day.py) both
call :func:`run_idle_day` with :class:`IdleDay`'s defaults, so they run the same day.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from cyborg.app.config import parse_config
from cyborg.app.robot import build_robot
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import SystemState

IDLE_DAY_CONFIG = """
states:
  idle: {action: cyborg_idle/idle, transitions: {music_play: music, joke_tell: joke, aborted: idle}}
  music: {action: cyborg_music/play, transitions: {succeeded: idle, aborted: idle}}
  joke: {action: cyborg_joke/tell, transitions: {succeeded: idle, aborted: idle}}
modules:
  cyborg_idle: {kind: idle}
  cyborg_music: {kind: placeholder, servers: [{action: cyborg_music/play, duration: 60}]}
  cyborg_joke: {kind: placeholder, servers: [{action: cyborg_joke/tell, say: "A joke.", duration: 5}]}
motivator:
  events:
    - {state: idle, event: music_play, reward_pleasure: 0.10, reward_arousal: 0.05}
    - {state: idle, event: joke_tell, reward_pleasure: 0.05, reward_arousal: 0.05, reward_dominance: 0.05}
"""
IDLE_STATE = "idle"


@dataclass(frozen=True)
class IdleDay:
    """What is simulated and what the day must show."""

    hours: float = 8.0
    idle_limit_seconds: float = 120.0
    """The robot may stay in the idle state at most this long at a time (a spell still running counts)."""
    max_share: float = 0.8
    """No event may take a larger share of the motivator's choices."""
    config: str = IDLE_DAY_CONFIG


@dataclass(frozen=True)
class IdleDayReport:
    """What happened during the day."""

    day: IdleDay
    chosen: dict[str, int]
    idle_spells: list[float]
    wall_seconds: float
    changes: list[tuple[float, str, str, str]] = field(repr=False)
    """Every state change: (virtual seconds, from, event, to)."""

    @property
    def total(self) -> int:
        return sum(self.chosen.values())

    @property
    def longest_idle(self) -> float:
        return max(self.idle_spells, default=0.0)

    def problems(self) -> list[str]:
        """Where the day missed the goals; empty when it met them."""
        found = []
        if self.total == 0:
            found.append("the motivator chose nothing all day")
        if self.longest_idle > self.day.idle_limit_seconds:
            found.append(
                f"idle for {self.longest_idle:.0f} s at a time, over the limit of "
                f"{self.day.idle_limit_seconds:.0f} s"
            )
        for event, count in self.chosen.items():
            if count / self.total > self.day.max_share:
                found.append(f"{event} took {count / self.total:.0%} of {self.total} choices")
        return found


def idle_spells(changes: Iterable[tuple[float, str, str]], end: float, idle: str = IDLE_STATE) -> list[float]:
    """Durations of the stays in ``idle``, from (time, from, to) state changes; a stay still
    running at ``end`` counts up to ``end``. A transition from idle to idle does not end a stay."""
    spells = []
    entered: float | None = None
    for t, source, target in changes:
        if target == idle and source != idle:
            entered = t
        elif source == idle and target != idle and entered is not None:
            spells.append(t - entered)
            entered = None
    if entered is not None:
        spells.append(end - entered)
    return spells


def run_idle_day(data_dir: Path, day: IdleDay | None = None) -> IdleDayReport:
    """Simulate ``day`` (by default 8 h) with its databases in ``data_dir``."""
    day = day or IdleDay()
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    changes: list[tuple[float, str, str, str]] = []

    def on_change(m: SystemState, info: MessageInfo) -> None:
        changes.append((clock.monotonic(), m.from_system_state, m.event, m.to_system_state))

    robot = build_robot(parse_config(day.config), transport, data_dir=data_dir)
    transport.node("idle_day_watch").subscribe(topics.STATE_CHANGE, SystemState, on_change, queue_size=1000)
    start = clock.monotonic()
    robot.start()
    started = time.perf_counter()
    try:
        clock.run(clock.sleep(day.hours * 3600))
        wall = time.perf_counter() - started
        end = clock.monotonic()
    finally:
        clock.close()
    spells = idle_spells(((t - start, a, b) for t, a, _, b in changes), end - start)
    return IdleDayReport(day, dict(robot.motivator.chosen), spells, wall, changes)
