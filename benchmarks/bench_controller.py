"""Controller benchmark on the embedded transport, in real time.

* handover latency: event published -> next module's goal ACTIVE (p50, p99 over N handovers);
* sustained throughput: events per second with a mix of valid and invalid events.

Run: .venv/bin/python benchmarks/bench_controller.py [--handovers 2000]
"""

from __future__ import annotations

import argparse
import time

from _machine import machine_line, percentile

from cyborg.app.config import parse_config
from cyborg.controller.runtime import Controller, Phase
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, Node, ServerGoalHandle
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import StateMachineAction, String

MACHINE = """
states:
  idle: {action: bench/a, transitions: {to_b: b, aborted: idle}}
  b: {action: bench/b, transitions: {to_a: idle, aborted: idle}}
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


def bench(handovers: int, throughput_events: int) -> dict[str, float]:
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    stamps: list[float] = []
    StampingModule(transport.node("mod_a"), "bench/a", stamps)
    StampingModule(transport.node("mod_b"), "bench/b", stamps)
    sender = transport.node("sender")
    publish = sender.publisher(topics.REGISTER_EVENT, String).publish
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)

    async def settle() -> None:
        while controller.phase is not Phase.ACTIVE or controller._queue:
            await clock.sleep(0)

    async def main() -> dict[str, float]:
        controller.start()
        await clock.sleep(0.05)
        latencies = []
        for i in range(handovers):
            before = len(stamps)
            sent = time.perf_counter()
            publish(String("to_b" if i % 2 == 0 else "to_a"))
            while len(stamps) == before:
                await clock.sleep(0)
            latencies.append((stamps[-1] - sent) * 1000)
            await settle()
        # throughput: batches of 50 events, 10 % valid
        batch = 50
        received_before = controller.stats.events_received
        start = time.perf_counter()
        toggle = 0
        for n in range(0, throughput_events, batch):
            for k in range(batch):
                if k % 10 == 0:
                    publish(String("to_b" if toggle % 2 == 0 else "to_a"))
                    toggle += 1
                else:
                    publish(String(f"not_a_transition_{k}"))
            while controller.stats.events_received - received_before < n + batch:
                await clock.sleep(0)
            await settle()
        elapsed = time.perf_counter() - start
        return {
            "handovers": float(handovers),
            "p50_ms": percentile(latencies, 50),
            "p99_ms": percentile(latencies, 99),
            "max_ms": max(latencies),
            "events": float(throughput_events),
            "events_per_s": throughput_events / elapsed,
            "valid_share": 0.1,
        }

    try:
        return clock.run(main())
    finally:
        clock.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--handovers", type=int, default=2000)
    parser.add_argument("--events", type=int, default=100_000)
    args = parser.parse_args()
    result = bench(args.handovers, args.events)
    print(f"machine: {machine_line()}")
    print("| measure | value | target |")
    print("|---|---|---|")
    print(f"| handover latency p50 ({int(result['handovers'])} handovers) | {result['p50_ms']:.3f} ms | |")
    print(f"| handover latency p99 | {result['p99_ms']:.3f} ms | < 1 ms |")
    print(f"| handover latency max | {result['max_ms']:.3f} ms | |")
    print(
        f"| sustained events/s ({int(result['events'])} events, 10 % valid) | {result['events_per_s']:,.0f} | >= 20,000 |"
    )


if __name__ == "__main__":
    main()
