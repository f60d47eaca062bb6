"""The controller's loop with a machine of 5,000 states: handovers, garbage collection and
what the dashboard polls.

Builds the whole in-process robot of a generated machine (cyborg.testing.machines.structured: a hub,
superstates of 5-20 states, one placeholder module serving every leaf) on the embedded transport in
real time, then:

* handover latency: an event valid in the active state published -> the controller's goal for the
  next state ACTIVE (p50, p99, max over N handovers of a random walk), once with what the build
  made frozen out of garbage collections (what Robot.start does) and once thawed (as before);
* how long a full garbage collection (``gc.collect()``) holds the loop, frozen and thawed;
* /api/health and /api/status (what the dashboard polls every second): median and max ms.

Run: .venv/bin/python benchmarks/bench_big_machine.py [--states 5000] [--handovers 2000]
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import random
import statistics
import tempfile
import time
from pathlib import Path

import yaml
from _machine import machine_line, percentile

from cyborg.app.config import parse_config
from cyborg.app.robot import build_robot
from cyborg.app.tuning import freeze_built, thaw
from cyborg.testing.machines import structured
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String
from cyborg.web.api import RobotAPI
from cyborg.web.dashboard import Dashboard


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--states", type=int, default=5000)
    parser.add_argument("--handovers", type=int, default=2000)
    args = parser.parse_args()
    text = yaml.safe_dump(structured(args.states), sort_keys=False, default_flow_style=None, width=10_000)
    config = parse_config(text, "generated.yaml")
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    rng = random.Random(1)
    pauses: list[tuple[int, float]] = []
    began: list[float] = []

    def on_gc(phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            began.append(time.perf_counter())
        elif began:
            pauses.append((info["generation"], (time.perf_counter() - began.pop()) * 1000))

    with tempfile.TemporaryDirectory() as scratch:
        robot = build_robot(config, transport, data_dir=Path(scratch), seed=1)
        controller = robot.controller
        api = RobotAPI(transport.node("cyborg_api"), machine=config.machine)
        dashboard = Dashboard(api, robot)
        publish = transport.node("sender").publisher(topics.REGISTER_EVENT, String).publish

        async def handovers(count: int) -> list[float]:
            latencies = []
            for _ in range(count):
                state = controller.active_state or ""
                events = sorted(
                    e for e in config.machine.transitions_of(state) if e not in ("aborted", "succeeded")
                )
                event = rng.choice(events)
                target = config.machine.transitions_of(state)[event]
                sent = time.perf_counter()
                publish(String(event))
                while not (controller.active_state == target and controller.goal_status is GoalStatus.ACTIVE):
                    await clock.sleep(0)
                latencies.append((time.perf_counter() - sent) * 1000)
            return latencies

        def full_collection_ms() -> float:
            start = time.perf_counter()
            gc.collect()
            return (time.perf_counter() - start) * 1000

        async def polled(handler: object, count: int = 200) -> list[float]:
            times = []
            for _ in range(count):
                start = time.perf_counter()
                await handler(None)  # type: ignore[operator]
                times.append((time.perf_counter() - start) * 1000)
                await asyncio.sleep(0)
            return times

        async def run() -> dict[str, object]:
            robot.start()  # freezes what the build made (cyborg.app.tuning)
            await clock.sleep(0.2)
            await handovers(args.handovers // 4)  # warm up
            gc.callbacks.append(on_gc)
            results: dict[str, object] = {}
            results["frozen_collect"] = full_collection_ms()
            pauses.clear()
            results["frozen"] = (await handovers(args.handovers), list(pauses))
            thaw()
            results["thawed_collect"] = full_collection_ms()
            pauses.clear()
            results["thawed"] = (await handovers(args.handovers), list(pauses))
            freeze_built()
            gc.callbacks.remove(on_gc)
            results["health"] = await polled(dashboard.health)
            results["status"] = await polled(api.get_status)
            await controller.stop()
            return results

        try:
            results = clock.run(run())
        finally:
            robot.close()
            transport.shutdown()
            clock.close()
    leaves = len(config.machine.leaves())
    print(f"machine: {machine_line()}")
    print(
        f"| measure ({leaves} states, {args.handovers} handovers each) | frozen (Robot.start) | thawed (as before) |"
    )
    print("|---|---|---|")
    frozen, fpauses = results["frozen"]  # type: ignore[misc]
    thawed, tpauses = results["thawed"]  # type: ignore[misc]
    for name, q in (("p50", 50), ("p99", 99)):
        print(
            f"| handover latency {name} | {percentile(frozen, q):.3f} ms | {percentile(thawed, q):.3f} ms |"
        )
    print(f"| handover latency max | {max(frozen):.3f} ms | {max(thawed):.3f} ms |")
    for label, values in (("collections during the handovers", (fpauses, tpauses)),):
        f, t = values
        print(
            f"| {label}: count, longest | {len(f)}, {max((p for _, p in f), default=0):.2f} ms | "
            f"{len(t)}, {max((p for _, p in t), default=0):.2f} ms |"
        )
    print(
        f"| a full collection (gc.collect()) | {results['frozen_collect']:.1f} ms | {results['thawed_collect']:.1f} ms |"
    )
    for endpoint in ("health", "status"):
        times = results[endpoint]
        print(
            f"| /api/{endpoint}: median, max of 200 | {statistics.median(times):.3f} ms, {max(times):.3f} ms | |"  # type: ignore[arg-type]
        )


if __name__ == "__main__":
    main()
