"""Eight virtual hours of an otherwise idle robot with two motivational events.

Runs the same day as tests/motivator/test_motivator_component.py (cyborg.testing.idle_day)
and reports the wall time it took, how the motivator split its choices and the longest
stretch in idle (a stretch still running at the end counts).
Run: .venv/bin/python benchmarks/bench_idle_day.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from _machine import machine_line

from cyborg.testing.idle_day import IdleDay, run_idle_day


def main() -> None:
    day = IdleDay()
    with tempfile.TemporaryDirectory() as scratch:
        report = run_idle_day(Path(scratch), day)
    shares = ", ".join(
        f"{event} {count / report.total:.0%}"
        for event, count in sorted(report.chosen.items(), key=lambda item: -item[1])
    )
    print(f"machine: {machine_line()}")
    print("| measure | value |")
    print("|---|---|")
    print(f"| virtual time simulated | {day.hours:g} h |")
    print(
        f"| wall time | {report.wall_seconds:.2f} s ({day.hours * 3600 / report.wall_seconds:,.0f}x real time) |"
    )
    print(f"| motivator choices | {report.total} ({shares}; limit {day.max_share:.0%} each) |")
    print(
        f"| longest idle spell | {report.longest_idle:.0f} s (limit {day.idle_limit_seconds:.0f} s; "
        f"{len(report.idle_spells)} spells) |"
    )
    for problem in report.problems():
        print(f"PROBLEM: {problem}")


if __name__ == "__main__":
    main()
