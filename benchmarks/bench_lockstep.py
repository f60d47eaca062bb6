"""Lockstep time: a script's wall time over ROS 1 and ROS 2 beside the robot in one process.

Runs `cyborg sim --script S --speed max` in one process, with `--ros` and with `--ros2` (every part
its own node, in lockstep: docs/lockstep.md), for scenario A and for an empty day of HOURS virtual
hours, RUNS times each, interleaved so that a change in the machine's load falls on all three.
The run in one process is the floor of the same run. Reports wall-time medians, the ratio to the
floor, the grants and delta cycles of the last ROS run, and whether the state, say, heard and
emotion records were those of the run in one process.
`--scenarios a,b,c,d` runs those scenarios instead of A; `--hogs 3` keeps three CPU-bound
processes busy beside the runs (issue 26: the same records with three hogs beside).
Run: .venv/bin/python benchmarks/bench_lockstep.py [--hours 1] [--runs 3] [--only a|day]
     .venv/bin/python benchmarks/bench_lockstep.py --only a --scenarios a,b,c,d --runs 5 --hogs 3
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _machine import machine_line

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "tests" / "scenarios"
HOG = "while True: pass"
TRANSPORTS = {"one process": [], "ROS 1": ["--ros"], "ROS 2": ["--ros2"]}
SHARED = ("state", "say", "heard", "emotion")


def run(script: Path, flags: list[str], scratch: Path, tag: str) -> dict[str, object]:
    transcript = scratch / f"{tag}.jsonl"
    env = {**os.environ, "CYBORG_RECORDINGS_DIR": str(scratch / "recordings")}
    env.setdefault("ROS_MASTER_URI", "http://127.0.0.1:11391")
    env.setdefault("ROS_DOMAIN_ID", "77")
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    command = [sys.executable, "-m", "cyborg.cli", "--log-level", "ERROR", "sim", *flags]
    command += ["--script", str(script), "--speed", "max", "--transcript", str(transcript)]
    command += ["--db", str(scratch / f"{tag}-data")]
    began = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=7200)
    wall = time.perf_counter() - began
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stdout[-2000:]}{done.stderr[-2000:]}")
    grants = re.search(r"in (\d+) grants \((\d+) of them delta cycles\)", done.stdout)
    records = [json.loads(line) for line in transcript.read_text().splitlines()]
    shared = [json.dumps(r, sort_keys=True) for r in records if r["type"] in SHARED]
    return {
        "wall": wall,
        "grants": grants.group(0) if grants else "",
        "shared": shared,
        "written_off": "written off" in done.stdout + done.stderr,
    }


def measure(name: str, script: Path, runs: int, scratch: Path) -> None:
    results: dict[str, list[dict[str, object]]] = {transport: [] for transport in TRANSPORTS}
    for index in range(runs):
        for transport, flags in TRANSPORTS.items():
            tag = f"{name}-{transport.replace(' ', '_')}-{index}"
            results[transport].append(run(script, flags, scratch, tag))
    floor = statistics.median(float(r["wall"]) for r in results["one process"])  # type: ignore[arg-type]
    reference = results["one process"][0]["shared"]
    for transport, measured in results.items():
        walls = [float(r["wall"]) for r in measured]  # type: ignore[arg-type]
        median = statistics.median(walls)
        same = sum(r["shared"] == reference for r in measured)
        offs = sum(bool(r["written_off"]) for r in measured)
        print(
            f"| {name} | {transport} | {median:.1f} s ({' / '.join(f'{w:.1f}' for w in walls)}) | "
            f"{median / floor:.1f}x | {measured[-1]['grants'] or '-'} | {same} of {len(measured)} | {offs} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--hours", type=float, default=1.0, help="virtual hours of the empty day")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--only", choices=("a", "day"), help="only the scenarios or only the day")
    parser.add_argument("--scenarios", default="a", help="which scenarios, comma-separated (a,b,c,d)")
    parser.add_argument("--hogs", type=int, default=0, help="CPU-bound processes beside the runs")
    args = parser.parse_args()
    hogs = [subprocess.Popen([sys.executable, "-c", HOG]) for _ in range(args.hogs)]
    try:
        report(args)
    finally:
        for hog in hogs:
            hog.kill()


def report(args: argparse.Namespace) -> None:
    print(f"machine: {machine_line()}, load average at start {os.getloadavg()[0]:.1f}, {args.hogs} hogs")
    print(
        "| script | transport | wall (median; runs) | x one process | grants, last ROS run | same records | runs with write-offs |"
    )
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(prefix="cyborg-bench-lockstep-") as folder:
        scratch = Path(folder)
        if args.only != "day":
            for letter in args.scenarios.split(","):
                script = SCENARIOS / f"scenario_{letter.strip().lower()}.yaml"
                if not script.is_file():
                    raise SystemExit(f"--scenarios: no {script}; choose among a, b, c, d")
                measure(f"scenario {letter.strip().upper()}", script, args.runs, scratch)
        if args.only != "a":
            day = scratch / "day.yaml"
            day.write_text(f"start: 2026-11-23T08:00:00\nuntil: {int(args.hours * 3600)}\n", encoding="utf-8")
            measure(f"{args.hours:g} h day", day, args.runs, scratch)
    print(f"load average at end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
