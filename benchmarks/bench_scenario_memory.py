"""Peak memory of `cyborg sim --script` over long scripts: flat, or growing with the script's length?

For each length (virtual days, default 1 and 7) it writes a script of an otherwise idle robot
that is greeted once a virtual hour, runs it at --speed max with a transcript, in its own
process, and reports the process's peak RSS, the wall time and the records written.
Run: .venv/bin/python benchmarks/bench_scenario_memory.py [DAYS ...]
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _machine import machine_line

CYBORG = Path(sys.executable).with_name("cyborg")


def script(days: float) -> str:
    seconds = int(days * 86400)
    steps = "".join(f"  - at: {t}\n    say: hello robot\n" for t in range(1800, seconds, 3600))
    return f"until: {seconds}\nsteps:\n{steps}"


def run(days: float) -> tuple[float, float, int]:
    """(peak RSS in MB, wall seconds, records) of one run."""
    with tempfile.TemporaryDirectory() as scratch:
        path, transcript = Path(scratch) / "s.yaml", Path(scratch) / "t.jsonl"
        path.write_text(script(days), encoding="utf-8")
        began = time.perf_counter()
        command = ["sim", "--script", str(path), "--speed", "max", "--transcript", str(transcript)]
        process = subprocess.Popen([str(CYBORG), "--log-level", "ERROR", *command], stdout=subprocess.DEVNULL)
        _, status, usage = os.wait4(process.pid, 0)
        wall = time.perf_counter() - began
        if status != 0:
            raise SystemExit(f"cyborg sim --script failed for {days} days (status {status})")
        with transcript.open(encoding="utf-8") as lines:
            records = sum(1 for _ in lines)
    return usage.ru_maxrss / 1024, wall, records


def main() -> None:
    lengths = [float(a) for a in sys.argv[1:]] or [1.0, 7.0]
    print(f"machine: {machine_line()}")
    print("| virtual days | records | peak RSS | wall time |")
    print("|---|---|---|---|")
    for days in lengths:
        peak, wall, records = run(days)
        print(f"| {days:g} | {records:,} | {peak:.0f} MB | {wall:.0f} s |")


if __name__ == "__main__":
    main()
