"""Eight virtual hours of an otherwise idle robot with two motivational events.

Reports the wall time the simulation took, how the motivator split its choices
and the longest stretch in idle. Run: .venv/bin/python benchmarks/bench_idle_day.py
"""

from __future__ import annotations

import tempfile
import time
from collections import Counter
from pathlib import Path

from _machine import machine_line

from cyborg.controller.config import parse_config
from cyborg.sim.robot import build_robot
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import SystemState

CONFIG = """
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


def main() -> None:
    hours = 8
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    with tempfile.TemporaryDirectory() as scratch:
        robot = build_robot(parse_config(CONFIG), transport, data_dir=Path(scratch))
        idle_spells: list[float] = []
        entered = [0.0]

        def on_change(m: SystemState, info: MessageInfo) -> None:
            if m.to_system_state == "idle":
                entered[0] = clock.monotonic()
            elif m.from_system_state == "idle":
                idle_spells.append(clock.monotonic() - entered[0])

        transport.node("watch").subscribe(topics.STATE_CHANGE, SystemState, on_change, queue_size=1000)
        robot.start()
        started = time.perf_counter()
        clock.run(clock.sleep(hours * 3600))
        wall = time.perf_counter() - started
        chosen = Counter(robot.motivator.chosen)
        clock.close()
    total = sum(chosen.values())
    print(f"machine: {machine_line()}")
    print("| measure | value |")
    print("|---|---|")
    print(f"| virtual time simulated | {hours} h |")
    print(f"| wall time | {wall:.2f} s ({hours * 3600 / wall:,.0f}x real time) |")
    print(
        f"| motivator choices | {total} ({', '.join(f'{k} {v / total:.0%}' for k, v in chosen.most_common())}) |"
    )
    print(f"| longest idle spell | {max(idle_spells):.0f} s |")


if __name__ == "__main__":
    main()
