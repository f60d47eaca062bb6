"""Parallel states: the static clash check as machines grow, and handover latency inside a parallel state.

* static check: machines of 100, 1,000 and 5,000 states, each a hub state plus one parallel state
  of two regions (the second region 30 states, the first the rest), every leaf with three random
  events of a 60-event alphabet; the speaker is granted in both regions (arbitrated, so the
  check explores every reachable combination: its worst case). Median of the runs of
  ``explore()`` beside the floor measured in the same run: the plain reachability every machine
  has always been checked for (``MachineSpec.reachable``, leaves only, no combinations);
* a planted exclusive clash in the 5,000-state machine: the time to find it and its trace length;
* handover latency, embedded transport, real time, same run: an event published -> the next
  module's goal ACTIVE, once between two plain states and once inside a parallel state (one
  region moves, the other keeps its module), alternating in blocks; p50 and p99 of each.

Run: .venv/bin/python benchmarks/bench_parallel.py [--handovers 2000] [--runs 3]
"""

from __future__ import annotations

import argparse
import random
import statistics
import time
from typing import Any

import yaml
from _machine import machine_line, percentile

from cyborg.app.config import parse_config
from cyborg.controller.clashes import explore
from cyborg.controller.runtime import Controller, Phase
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, Node, ServerGoalHandle
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import StateMachineAction, String

ALPHABET = [f"e{i}" for i in range(60)]


def two_regions(states: int, *, policy: str = "arbitrated", seed: int = 1) -> dict[str, Any]:
    """A hub plus a parallel state of two regions, ``states`` states in all (leaves and superstates)."""
    rng = random.Random(seed)
    second = 30
    first = states - second - 4  # idle, busy, and the two regions themselves

    def region(prefix: str, count: int, priority: int, node: str) -> dict[str, Any]:
        names = [f"{prefix}{i}" for i in range(count)]
        leaves: dict[str, Any] = {}
        for i, name in enumerate(names):
            transitions = {rng.choice(ALPHABET): rng.choice(names) for _ in range(3)}
            transitions["succeeded"] = names[(i + 1) % count]
            leaves[name] = {"action": f"{prefix}/{name}", "transitions": transitions}
            if i % 7 == 3:
                leaves[name]["resources"] = {"speaker": node}
        return {"priority": priority, "states": leaves}

    return {
        "initial": "idle",
        "resource_policy": {"speaker": policy},
        "states": {
            "idle": {"action": "hub/idle", "transitions": {"go": "busy", "aborted": "idle"}},
            "busy": {
                "parallel": True,
                "transitions": {"stop": "idle", "aborted": "idle"},
                "states": {
                    "behaviour": region("b", first, 1, "behaviour_node"),
                    "monitor": region("m", second, 10, "monitor_node"),
                },
            },
        },
    }


def _text(machine: dict[str, Any]) -> str:
    return yaml.safe_dump(machine, sort_keys=False, default_flow_style=None, width=10_000)


def bench_check(sizes: list[int], runs: int) -> None:
    print("| states | combinations reached | check (median) | floor: plain reachability | ratio |")
    print("|---|---|---|---|---|")
    for size in sizes:
        machine = parse_config(_text(two_regions(size)), f"{size}.yaml").machine
        checks, floors = [], []
        found = None
        for _ in range(runs):
            start = time.perf_counter()
            machine.reachable()
            floors.append(time.perf_counter() - start)
            start = time.perf_counter()
            found = explore(machine)
            checks.append(time.perf_counter() - start)
        assert found is not None and not found.clashes
        check, floor = statistics.median(checks), statistics.median(floors)
        print(
            f"| {size:,} | {found.parallel_configurations:,} | {check * 1000:,.1f} ms | "
            f"{floor * 1000:,.1f} ms | {check / floor:,.0f}x |"
        )
    machine = parse_config(_text(two_regions(5000)), "clean.yaml").machine
    planted = two_regions(5000, policy="exclusive")
    text = _text(planted)
    start = time.perf_counter()
    try:
        parse_config(text, "planted.yaml")
    except Exception as exc:
        problems = getattr(exc, "problems", [str(exc)])
        elapsed = time.perf_counter() - start
        traces = [p.split("reached by ")[1].split(";")[0].count("->") for p in problems if "reached by" in p]
        print(
            f"\nplanted exclusive speaker, 5,000 states: validation (load + check) {elapsed:.2f} s; "
            f"{problems[-1].split(';')[0]}; traces shown {min(traces)}-{max(traces)} events"
        )
    del machine


PLAIN_AND_PARALLEL = """
resource_policy: {speaker: arbitrated}
states:
  idle: {action: bench/a, transitions: {to_b: b, go: busy, aborted: idle}}
  b: {action: bench/b, transitions: {to_a: idle, aborted: idle}}
  busy:
    parallel: true
    transitions: {stop: idle, aborted: idle}
    states:
      behaviour:
        priority: 1
        states:
          p1: {action: bench/p1, resources: {speaker: m1}, transitions: {flip: p2}}
          p2: {action: bench/p2, transitions: {flip: p1}}
      monitor:
        priority: 10
        states:
          q1: {action: bench/q1, resources: {speaker: m2}, transitions: {other: q1}}
"""


class StampingModule:
    """Accepts goals at once, records when each became ACTIVE, acknowledges cancels at once."""

    def __init__(self, node: Node, action: str, stamps: list[float]) -> None:
        self.stamps = stamps
        node.action_server(action, StateMachineAction, self.on_goal, lambda h: h.canceled())

    def on_goal(self, handle: ServerGoalHandle) -> None:  # type: ignore[type-arg]
        handle.accept()
        if handle.status is GoalStatus.ACTIVE:
            self.stamps.append(time.perf_counter())


def bench_handover(handovers: int) -> dict[str, list[float]]:
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    stamps: list[float] = []
    for action in ("a", "b", "p1", "p2", "q1"):
        StampingModule(transport.node(f"mod_{action}"), f"bench/{action}", stamps)
    publish = transport.node("sender").publisher(topics.REGISTER_EVENT, String).publish
    controller = Controller(transport.node("cyborg_controller"), parse_config(PLAIN_AND_PARALLEL).machine)

    async def settle() -> None:
        while controller.phase is not Phase.ACTIVE or controller._queue:
            await clock.sleep(0)

    async def one(event: str) -> float:
        before = len(stamps)
        sent = time.perf_counter()
        publish(String(event))
        while len(stamps) == before:
            await clock.sleep(0)
        latency = (stamps[-1] - sent) * 1000
        await settle()
        return latency

    async def main() -> dict[str, list[float]]:
        controller.start()
        await clock.sleep(0.05)
        out: dict[str, list[float]] = {"plain": [], "parallel": []}
        block = 100
        for _ in range(handovers // (2 * block)):
            for i in range(block):
                out["plain"].append(await one("to_b" if i % 2 == 0 else "to_a"))
            await one("go")
            await settle()
            for _ in range(block):
                out["parallel"].append(await one("flip"))
            await one("stop")
        return out

    try:
        return clock.run(main())
    finally:
        clock.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--handovers", type=int, default=2000)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--sizes", default="100,1000,5000")
    args = parser.parse_args()
    print(f"machine: {machine_line()}\n")
    bench_check([int(s) for s in args.sizes.split(",")], args.runs)
    result = bench_handover(args.handovers)
    print("\n| handover | n | p50 | p99 |")
    print("|---|---|---|---|")
    for kind, values in result.items():
        print(
            f"| {kind} | {len(values)} | {percentile(values, 50):.3f} ms | {percentile(values, 99):.3f} ms |"
        )
    ratio = percentile(result["parallel"], 99) / percentile(result["plain"], 99)
    print(f"\nparallel / plain p99: {ratio:.2f}x")


if __name__ == "__main__":
    main()
