"""Benchmark (not a test): drawing the state machine as it grows.

For structured machines (superstates of 5-20 states) and random ones at 17, 100, 1,000 and 5,000
states: the time and peak memory of the layout one superstate at a time plus Graphviz's drawing
(each in its own process, so its peak RSS is its own and a runaway one is killed at the timeout),
the old one-shot ``dot`` on the same machine for comparison (smaller sizes only), and the
dashboard's first paint in headless Chromium (page load until the graph is drawn with its
states marked). Prints medians as Markdown rows for docs/benchmarks-history.md.

    .venv/bin/python benchmarks/bench_dashboard_layout.py [--repeats 3] [--no-browser]
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml
from _machine import machine_line

SIZES = (17, 100, 1000, 5000)
KINDS = ("structured", "random")
TIMEOUT = 120.0  # seconds before a layout is killed
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking"]

LAYOUT = """
import sys
from cyborg.testing.machines import machine_spec, random_machine, structured
from cyborg.drawing.layout import draw, lay_out
make = structured if sys.argv[1] == "structured" else random_machine
machine = machine_spec(make(int(sys.argv[2])))
if sys.argv[3] == "new":
    draw(lay_out(machine))
else:
    import subprocess
    from cyborg.drawing.graph import to_graph
    subprocess.run(["dot", "-Tsvg"], input=to_graph(machine).source.encode(), capture_output=True)
"""

BASELINE = """
import sys
from cyborg.testing.machines import machine_spec, random_machine, structured
make = structured if sys.argv[1] == "structured" else random_machine
machine_spec(make(int(sys.argv[2])))
"""


def in_process(code: str, *args: str, timeout: float = TIMEOUT) -> tuple[float | None, float]:
    """Run ``code`` in a fresh Python; (seconds or None if killed, peak RSS in MiB of it and its children)."""
    began = time.perf_counter()
    process = subprocess.Popen([sys.executable, "-c", code, *args], stdout=subprocess.DEVNULL)
    deadline = began + timeout
    while True:
        pid, status, usage = os.wait4(process.pid, os.WNOHANG)
        if pid:
            break
        if time.perf_counter() > deadline:
            process.kill()
            _, _, usage = os.wait4(process.pid, 0)
            return None, usage.ru_maxrss / 1024
        time.sleep(0.005)
    if status != 0:
        raise SystemExit(f"the layout of {args} failed (status {status})")
    return time.perf_counter() - began, usage.ru_maxrss / 1024


def first_paint(kind: str, size: int) -> float:
    """Seconds from opening the dashboard of a robot running the machine until its graph is drawn."""
    from playwright.sync_api import sync_playwright

    from cyborg.testing.machines import random_machine, structured

    make = structured if kind == "structured" else random_machine
    with tempfile.TemporaryDirectory() as folder:
        config = Path(folder) / "machine.yaml"
        config.write_text(yaml.safe_dump(make(size), sort_keys=False, default_flow_style=True, width=10**9))
        log = Path(folder) / "sim.log"
        with log.open("w") as out:
            sim = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "cyborg.cli",
                    "sim",
                    "--port",
                    "0",
                    "--db",
                    folder,
                    "--config",
                    str(config),
                ],
                stdout=out,
                stderr=subprocess.STDOUT,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
        try:
            match = None
            deadline = time.monotonic() + 60
            while match is None and time.monotonic() < deadline:
                time.sleep(0.05)
                match = re.search(r"(http://127\.0\.0\.1:\d+)/", log.read_text())
            if match is None:
                raise SystemExit("cyborg sim did not start:\n" + log.read_text())
            with sync_playwright() as playwright:
                browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
                page = browser.new_page(viewport={"width": 1280, "height": 800})
                began = time.perf_counter()
                page.goto(match.group(1) + "/")
                page.wait_for_function(
                    "() => document.querySelector('#graph .node.active') || "
                    "document.querySelector('#graph .cluster.active-inside')",
                    timeout=120_000,
                )
                page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
                seconds = time.perf_counter() - began
                browser.close()
            return seconds
        finally:
            sim.terminate()
            sim.wait(timeout=20)


def median(values: list[float | None]) -> str:
    done = [v for v in values if v is not None]
    if len(done) < len(values):
        return f"> {TIMEOUT:g} s (killed)"
    return f"{statistics.median(done):.2f} s"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-browser", action="store_true")
    parser.add_argument(
        "--old-up-to", type=int, default=100, help="largest size to run the old one-shot dot on"
    )
    parser.add_argument("--sizes", type=int, nargs="*", default=list(SIZES))
    parser.add_argument("--kinds", nargs="*", default=list(KINDS))
    options = parser.parse_args()
    print(machine_line())
    print(
        "| machine | states | layout + drawing | peak RSS | floor (generate only) | one-shot dot (before) | first paint |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for kind in options.kinds:
        for size in options.sizes:
            runs = [in_process(LAYOUT, kind, str(size), "new") for _ in range(options.repeats)]
            floor = [in_process(BASELINE, kind, str(size)) for _ in range(options.repeats)]
            old = "not run"
            if size <= options.old_up_to:
                before = in_process(LAYOUT, kind, str(size), "old", timeout=60.0)
                old = (
                    f"{before[0]:.2f} s, {before[1]:.0f} MiB"
                    if before[0] is not None
                    else f"> 60 s (killed, {before[1]:.0f} MiB)"
                )
            paint = "not run"
            if not options.no_browser and kind == "structured":
                paint = f"{statistics.median(first_paint(kind, size) for _ in range(options.repeats)):.2f} s"
            print(
                f"| {kind} | {size} | {median([r[0] for r in runs])} | "
                f"{statistics.median(r[1] for r in runs):.0f} MiB | {median([f[0] for f in floor])}, "
                f"{statistics.median(f[1] for f in floor):.0f} MiB | {old} | {paint} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
