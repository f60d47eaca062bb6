"""The flight recorder: what recording costs a simulated day, its size, seeks, replay's first paint.

Runs the packaged robot's 8-hour day (`cyborg sim --script` of `until: 28800`, `--speed max`, a
transcript) RUNS times without recording (`--no-record`) and RUNS times with (`--record`),
alternating in the same run, and reports the medians of wall and CPU time and their ratio. Then,
on the last recording: its size, a week of robot days (24 h = 3 of these) against the default
budget, the time to read a 60 s window at SEEKS random moments through the MCAP index and to
answer `/api/status?at=` (p50/p95), the replay page's first paint (`cyborg replay` started,
Chromium, already running, opens the page, until it shows t = 0; median of 3, alternating with
the same on a one-minute recording as the floor), and the CPU the
recorder alone takes to write the day's records again in this process (what the ratio's
difference should be, without the noise of a loaded machine).
Run: .venv/bin/python benchmarks/bench_recorder.py [--hours 8] [--runs 3] [--seeks 200]
"""

from __future__ import annotations

import argparse
import os
import random
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _machine import machine_line, percentile

CYBORG = [sys.executable, "-m", "cyborg.cli"]


def day(hours: float, scratch: Path, record: Path | None) -> dict[str, float]:
    script, transcript = scratch / "day.yaml", scratch / "t.jsonl"
    script.write_text(f"until: {int(hours * 3600)}\n", encoding="utf-8")
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    args = [*CYBORG, "--log-level", "ERROR", "sim", "--script", str(script), "--speed", "max"]
    args += ["--transcript", str(transcript)]
    args += ["--record", str(record)] if record is not None else ["--no-record"]
    if record is not None and record.exists():
        record.unlink()
    began = time.perf_counter()
    process = subprocess.Popen(args, stdout=subprocess.DEVNULL, env=env)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - began
    if status != 0:
        raise SystemExit(f"cyborg sim --script failed (status {status})")
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime}


def recorder_cpu(records: list[dict[str, object]], scratch: Path) -> float:
    """CPU seconds the recorder takes to write ``records`` (the day's), alone in this process."""
    from cyborg.observe.recorder import Recorder, RecorderSettings, RunFacts
    from cyborg.observe.records import RecordStream
    from cyborg.transport.clock import VirtualClock
    from cyborg.transport.embedded import EmbeddedTransport

    clock = VirtualClock(speed=None)
    transport = EmbeddedTransport(clock)
    node = transport.node("cyborg_recorder")
    settings = RecorderSettings(file=scratch / "again.mcap")
    recorder = Recorder(node, RecordStream(node), settings, RunFacts(start_ns=0, clock="virtual"))
    began = time.process_time()
    for record in records:
        recorder.on_record(record)
    recorder.close()
    took = time.process_time() - began
    transport.shutdown()
    clock.close()
    return took


def first_paint(recording: Path) -> float:
    from playwright.sync_api import sync_playwright

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.dashboard.test_dashboard_browser import CHROMIUM, CHROMIUM_ARGS

    with tempfile.TemporaryDirectory() as scratch, sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page()  # the browser is up first: its start is no part of the replay's
        log = Path(scratch) / "replay.log"
        began = time.perf_counter()
        with log.open("w") as out:
            process = subprocess.Popen(
                [*CYBORG, "replay", str(recording), "--port", "0"], stdout=out, stderr=subprocess.STDOUT
            )
        try:
            url = None
            while url is None:
                found = re.search(r"http://\S+/", log.read_text())
                url = found.group(0) if found else None
                time.sleep(0.01)
            page.goto(url)
            page.wait_for_selector("body[data-shown='0']")
            painted = time.perf_counter() - began
        finally:
            browser.close()
            process.terminate()
            process.wait(timeout=10)
    return painted


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--hours", type=float, default=8.0)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--seeks", type=int, default=200)
    args = parser.parse_args()
    from cyborg.observe.recorder import DEFAULT_BUDGET_BYTES
    from cyborg.observe.recording import open_recording, window
    from cyborg.web.replay import ReplayAPI

    with tempfile.TemporaryDirectory() as scratch_name:
        scratch = Path(scratch_name)
        recording = scratch / "day.mcap"
        without: list[dict[str, float]] = []
        with_: list[dict[str, float]] = []
        for _ in range(args.runs):
            without.append(day(args.hours, scratch, None))
            with_.append(day(args.hours, scratch, recording))
        size = recording.stat().st_size
        began = time.perf_counter()
        read = open_recording(recording)
        read_whole = time.perf_counter() - began
        end_ns = read.end_ns
        rng = random.Random(1)
        seeks = []
        for _ in range(args.seeks):
            at = rng.randrange(0, max(1, end_ns - 60_000_000_000))
            began = time.perf_counter()
            window(recording, at, at + 60_000_000_000)
            seeks.append((time.perf_counter() - began) * 1000)
        api = ReplayAPI(read)
        statuses = []
        for _ in range(args.seeks):
            at = rng.randrange(0, max(1, end_ns))
            began = time.perf_counter()
            api.status_at(at)
            statuses.append((time.perf_counter() - began) * 1000)
        minute = scratch / "minute.mcap"  # the floor: the same replay of a one-minute recording
        day(60 / 3600, scratch, minute)
        paints, floors = [], []
        for _ in range(3):
            paints.append(first_paint(recording))
            floors.append(first_paint(minute))
        writing = recorder_cpu(read.records, scratch)

    def med(runs: list[dict[str, float]], key: str) -> float:
        return statistics.median(r[key] for r in runs)

    week = size * 7 * 24 / args.hours
    print(f"machine: {machine_line()}, load average {os.getloadavg()[0]:.1f}")
    print(f"| measure ({args.hours:g} virtual hours, median of {args.runs}, alternating) | value |")
    print("|---|---|")
    print(f"| wall without recording (floor) | {med(without, 'wall'):.2f} s |")
    print(f"| wall with recording | {med(with_, 'wall'):.2f} s |")
    print(f"| wall ratio | {med(with_, 'wall') / med(without, 'wall'):.3f} |")
    print(f"| CPU without / with | {med(without, 'cpu'):.2f} s / {med(with_, 'cpu'):.2f} s |")
    print(f"| CPU ratio | {med(with_, 'cpu') / med(without, 'cpu'):.3f} |")
    every = " / ".join(", ".join(f"{r['cpu']:.2f}" for r in runs) for runs in (without, with_))
    print(f"| CPU of each run, without / with | {every} s |")
    print(
        f"| the recorder alone: the day's records written again (CPU) | {writing:.2f} s "
        f"({writing / max(1, len(read.records)) * 1e6:.1f} us a record) |"
    )
    print(f"| recording size | {size / 1e6:.2f} MB ({len(read.records)} records) |")
    print(
        f"| a week of 24 h days | {week / 1e6:.0f} MB of the default budget's "
        f"{DEFAULT_BUDGET_BYTES / 1e6:.0f} MB |"
    )
    print(f"| read the whole recording | {read_whole * 1000:.0f} ms |")
    print(
        f"| seek: a 60 s window through the index ({args.seeks}) | p50 {statistics.median(seeks):.1f} ms, "
        f"p95 {percentile(seeks, 95):.1f} ms |"
    )
    print(
        f"| /api/status?at= ({args.seeks}) | p50 {statistics.median(statuses) * 1000:.0f} us, "
        f"p95 {percentile(statuses, 95) * 1000:.0f} us |"
    )
    paint, floor = statistics.median(paints), statistics.median(floors)
    print(f"| replay first paint, one-minute recording (floor; median of 3, alternating) | {floor:.2f} s |")
    print(
        f"| replay first paint, the day's recording (median of 3) | {paint:.2f} s ({paint / floor:.2f}x the floor) |"
    )


if __name__ == "__main__":
    main()
