"""The whole packaged robot in virtual time: wall time per virtual hour, beside the reduced robot's.

Runs `cyborg sim --script` on the packaged configuration (every module, the simulated base on the
campus map) with a script of `until: HOURS x 3600` and no steps, `--speed max`, a transcript, in its
own process, RUNS times; then, in this process, the reduced robot of bench_idle_day.py (idle module,
two motivational events) for the same number of hours. Reports wall and CPU time (medians), wall
seconds per virtual hour, peak RSS and records written.
Run: .venv/bin/python benchmarks/bench_whole_day.py [--hours 8] [--runs 3] [--src DIR] [--config FILE]
(--src puts another checkout's src first on PYTHONPATH, to measure a commit before a change.)
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from _machine import machine_line

CYBORG = Path(sys.executable).with_name("cyborg")


def whole_robot(hours: float, src: str | None, config: str | None) -> dict[str, float]:
    """One run of the packaged robot: wall s, CPU s, peak RSS MB, records."""
    with tempfile.TemporaryDirectory() as scratch:
        script, transcript = Path(scratch) / "day.yaml", Path(scratch) / "t.jsonl"
        script.write_text(f"until: {int(hours * 3600)}\n", encoding="utf-8")
        env = dict(os.environ)
        # As on a user's machine, Python keeps compiled modules: without this (some sandboxes set
        # it) every run compiles the package's sources again.
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        if src:
            env["PYTHONPATH"] = os.pathsep.join(filter(None, [src, env.get("PYTHONPATH")]))
        args = [str(CYBORG), "--log-level", "ERROR", "sim", "--script", str(script), "--speed", "max"]
        args += ["--transcript", str(transcript), *(["--config", config] if config else [])]
        began = time.perf_counter()
        process = subprocess.Popen(args, stdout=subprocess.DEVNULL, env=env)
        helpers = _HelperPeaks(process.pid)
        _, status, usage = os.wait4(process.pid, 0)
        wall = time.perf_counter() - began
        helpers.stop()
        if status != 0:
            raise SystemExit(f"cyborg sim --script failed (status {status})")
        with transcript.open(encoding="utf-8") as lines:
            records = sum(1 for _ in lines)
    return {
        "wall": wall,
        "cpu": usage.ru_utime + usage.ru_stime,
        "rss": usage.ru_maxrss / 1024,
        "helper_rss": helpers.peak_kb / 1024,
        "records": float(records),
    }


class _HelperPeaks:
    """The largest peak RSS (VmHWM) of the robot's own child processes (the base's route-search
    worker, and multiprocessing's resource tracker), read from /proc every 0.1 s while it runs:
    ``wait4`` reports the robot process's peak, or a child's if larger, not their sum."""

    def __init__(self, pid: int) -> None:
        self.pid = pid
        self.peak_kb = 0
        self._seen: dict[int, int] = {}
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()

    def _watch(self) -> None:
        while not self._done.wait(0.1):
            for status in Path("/proc").glob("[0-9]*/status"):
                try:
                    fields = dict(
                        line.split(":", 1) for line in status.read_text().splitlines() if ":" in line
                    )
                except OSError:
                    continue
                if fields.get("PPid", "").strip() == str(self.pid) and "VmHWM" in fields:
                    child = int(status.parent.name)
                    self._seen[child] = int(fields["VmHWM"].split()[0])
            self.peak_kb = max(self._seen.values(), default=0)

    def stop(self) -> None:
        self._done.set()
        self._thread.join()


def reduced_robot(hours: float) -> float:
    """Wall seconds of bench_idle_day.py's robot for ``hours`` virtual hours."""
    from cyborg.testing.idle_day import IdleDay, run_idle_day

    with tempfile.TemporaryDirectory() as scratch:
        return run_idle_day(Path(scratch), IdleDay(hours=hours)).wall_seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--hours", type=float, default=8.0)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--src", help="another checkout's src folder, first on PYTHONPATH")
    parser.add_argument("--config", help="robot YAML (default: the packaged one)")
    parser.add_argument("--no-reduced", action="store_true", help="skip the reduced robot")
    args = parser.parse_args()
    runs = [whole_robot(args.hours, args.src, args.config) for _ in range(args.runs)]
    reduced = [] if args.no_reduced else [reduced_robot(args.hours) for _ in range(args.runs)]
    wall = statistics.median(r["wall"] for r in runs)
    print(f"machine: {machine_line()}, load average {os.getloadavg()[0]:.1f}")
    print(f"| measure ({args.hours:g} virtual hours, median of {args.runs}) | value |")
    print("|---|---|")
    print(
        f"| whole robot: wall | {wall:.1f} s ({args.hours * 3600 / wall:,.0f}x real time; runs "
        + " / ".join(f"{r['wall']:.1f}" for r in runs)
        + " s) |"
    )
    print(f"| whole robot: wall per virtual hour | {wall / args.hours:.2f} s |")
    print(f"| whole robot: CPU (user + system) | {statistics.median(r['cpu'] for r in runs):.1f} s |")
    print(f"| whole robot: peak RSS | {max(r['rss'] for r in runs):.0f} MB |")
    print(
        f"| whole robot: largest child process (route-search worker), peak RSS | {max(r['helper_rss'] for r in runs):.0f} MB |"
    )
    print(f"| whole robot: transcript records | {int(runs[0]['records']):,} |")
    if reduced:
        median = statistics.median(reduced)
        print(
            f"| reduced robot (bench_idle_day.py): wall per virtual hour | {median / args.hours:.2f} s "
            f"({median:.1f} s; runs " + " / ".join(f"{w:.1f}" for w in reduced) + " s) |"
        )


if __name__ == "__main__":
    main()
