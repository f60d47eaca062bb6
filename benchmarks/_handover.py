"""Shared by the ROS 1 and ROS 2 handover benchmarks: alternating blocks, CPU time, the report.

A contender (ours, the floor, the floor without the event hop) has a ``name`` and a ``one()``
that makes one handover and returns its latency in ms. :func:`measure` runs them in alternating
blocks, back to back or paced; :func:`report` prints the table the benchmarks' docstrings and
docs/benchmarks.md describe, with the ratios of ours to the floor of the same run.
"""

from __future__ import annotations

import os
import random
import statistics
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

from _machine import percentile

PACED_PAUSE = (0.1, 0.3)  # seconds before each paced handover, as between a robot's events
PACED_BLOCK = 25


class Contender(Protocol):
    name: str

    def one(self) -> float: ...


def measure(
    contenders: Sequence[Contender], handovers: int, block: int, paced: bool, seed: int
) -> dict[str, list[list[float]]]:
    """``handovers`` of each contender in blocks of ``block``, taking turns (the order reversed
    every other round); paced: a random PACED_PAUSE before each. Returns each one's blocks."""
    rng = random.Random(seed)
    blocks: dict[str, list[list[float]]] = {c.name: [] for c in contenders}
    done = 0
    rounds = 0
    while done < handovers:
        n = min(block, handovers - done)
        for contender in contenders if rounds % 2 == 0 else list(contenders)[::-1]:
            times = []
            for _ in range(n):
                if paced:
                    time.sleep(rng.uniform(*PACED_PAUSE))
                times.append(contender.one())
            blocks[contender.name].append(times)
        done += n
        rounds += 1
    return blocks


def cpu_seconds(pid: int) -> float:
    """User and system CPU time of a process so far (from /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def load() -> float:
    return os.getloadavg()[0]


def _flat(blocks: list[list[float]]) -> list[float]:
    return [value for block in blocks for value in block]


def block_ratio(ours: list[list[float]], floor: list[list[float]]) -> float:
    """The median over the rounds of (ours' block p50 / the floor's block p50): robust to load
    that changes between rounds."""
    return statistics.median(percentile(a, 50) / percentile(b, 50) for a, b in zip(ours, floor, strict=True))


def report(result: dict[str, Any], target: str, floor_label: str, direct_label: str) -> None:
    """Print the latency table and the ratios (``result``: modes 'b2b' / 'paced' -> blocks)."""

    def row(label: str, values: list[float], note: str = "") -> str:
        return (
            f"| {label} | {percentile(values, 50):.2f} | {percentile(values, 99):.2f} | "
            f"{max(values):.2f} | {len(values)} | {note} |"
        )

    print("| handover | p50 ms | p99 ms | max ms | count | target |")
    print("|---|---:|---:|---:|---:|---|")
    ratios = []
    for mode, label in (("b2b", "back to back"), ("paced", "paced")):
        if mode not in result:
            continue
        blocks = result[mode]
        ours, floor = _flat(blocks["ours"]), _flat(blocks["floor"])
        print(
            row(f"{label}, ours: event -> next module's goal accepted or ACTIVE (server side)", ours, target)
        )
        print(row(f"{label}, floor: {floor_label}", floor))
        line = (
            f"{label}: ours/floor p50 **{percentile(ours, 50) / percentile(floor, 50):.2f}** "
            f"(median of the rounds' ratios {block_ratio(blocks['ours'], blocks['floor']):.2f}), "
            f"p99 {percentile(ours, 99) / percentile(floor, 99):.2f}"
        )
        if "direct" in blocks:
            direct = _flat(blocks["direct"])
            print(row(f"{label}, floor without the event hop: {direct_label}", direct))
            line += (
                f"; ours/floor without the event hop p50 {percentile(ours, 50) / percentile(direct, 50):.2f}"
            )
        ratios.append(line)
    for line in ratios:
        print(line)
