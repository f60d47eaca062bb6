"""Map loading and route planning benchmark on the real maps in ../shared/maps.

* load time of glassgarden.map (ARNL, rasterised at 0.05 m) and willow.yaml (map_server);
* the planner's preparation (inflation, free-area labelling) for each;
* planning time between every ordered pair of Glassgården's named places at 0.05 m:
  p50, p95, max and count, for routes found and for pairs refused (different floors).

With scikit-image installed it also times ``skimage.graph.MCP_Geometric`` on the same
pairs, as the reference for route length. Prints a markdown table (a new round for
docs/benchmarks-history.md, section "Route planning"); with --write also saves it to docs/bench-planner.md.

Run: .venv/bin/python benchmarks/bench_planner.py
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np
from _machine import machine_line, percentile

from cyborg.errors import PlanningError
from cyborg.maps import NamedPose, OccupancyMap, load_map
from cyborg.sim.planner import Route, RoutePlanner

PROJECT = Path(__file__).resolve().parent.parent
MAPS = PROJECT.parent / "shared" / "maps"
REPORT = PROJECT / "docs" / "bench-planner.md"

T = TypeVar("T")


def timed(make: Callable[[], T], repeats: int) -> tuple[T, list[float]]:
    """The last result of ``make()`` and the seconds each of ``repeats`` calls took."""
    seconds = []
    result: T | None = None
    for _ in range(repeats):
        started = time.perf_counter()
        result = make()
        seconds.append(time.perf_counter() - started)
    assert result is not None
    return result, seconds


def ms(seconds: float) -> str:
    return f"{seconds * 1000:.1f}"


def stats_row(label: str, seconds: list[float]) -> str:
    if not seconds:
        return f"| {label} | - | - | - | 0 |"
    return (
        f"| {label} | {ms(percentile(seconds, 50))} | {ms(percentile(seconds, 95))} "
        f"| {ms(max(seconds))} | {len(seconds)} |"
    )


def plan_all_pairs(planner: RoutePlanner) -> tuple[list[float], list[float], dict[tuple[str, str], Route]]:
    found, refused, routes = [], [], {}
    for start, goal in itertools.permutations(planner.map.poses, 2):
        started = time.perf_counter()
        try:
            route = planner.plan(start, goal)
        except PlanningError:
            refused.append(time.perf_counter() - started)
            continue
        found.append(time.perf_counter() - started)
        routes[(start.name, goal.name)] = route
    return found, refused, routes


def mcp_reference(planner: RoutePlanner, routes: dict[tuple[str, str], Route]) -> list[str]:
    """Time scikit-image's MCP_Geometric on the same pairs and compare route lengths."""
    try:
        from skimage.graph import MCP_Geometric
    except ImportError:
        return ["", "scikit-image is not installed: no MCP_Geometric comparison."]
    started = time.perf_counter()
    mcp = MCP_Geometric(np.where(planner.inflated, -1.0, 1.0), fully_connected=True)
    build = time.perf_counter() - started
    seconds, ratios = [], []
    for (start_name, goal_name), route in routes.items():
        start, goal = planner.map.pose(start_name), planner.map.pose(goal_name)
        start_cell, goal_cell = (
            planner.map.world_to_cell(*start.position),
            planner.map.world_to_cell(*goal.position),
        )
        started = time.perf_counter()
        mcp.find_costs([start_cell], [goal_cell])
        path = np.array(mcp.traceback(goal_cell))
        seconds.append(time.perf_counter() - started)
        reference = Route.through(planner._pull_taut(start.position, path, goal.position))
        ratios.append(route.length / reference.length)
    return [
        "",
        f"Reference, scikit-image MCP_Geometric (Dijkstra with true diagonal costs), one object "
        f"built in {ms(build)} ms and reused:",
        "",
        "| search | p50 ms | p95 ms | max ms | count |",
        "| --- | ---: | ---: | ---: | ---: |",
        stats_row("MCP_Geometric find_costs + traceback", seconds),
        "",
        f"Route length, pyastar2d route / MCP route (both pulled taut the same way): "
        f"mean {statistics.fmean(ratios):.4f}, worst {max(ratios):.4f}, best {min(ratios):.4f}.",
    ]


def load_section(repeats: int) -> tuple[list[str], OccupancyMap, list[float]]:
    glassgarden, glassgarden_load = timed(
        lambda: load_map(MAPS / "glassgarden.map", resolution=0.05), repeats
    )
    willow, willow_load = timed(lambda: load_map(MAPS / "willow.yaml"), repeats)
    _, glassgarden_prep = timed(lambda: RoutePlanner(glassgarden), repeats)
    _, willow_prep = timed(lambda: RoutePlanner(willow), repeats)

    def row(label: str, occupancy_map: OccupancyMap, load: list[float], prep: list[float]) -> str:
        rows, cols = occupancy_map.shape
        return (
            f"| {label} | {cols} x {rows} @ {occupancy_map.resolution:g} m | {ms(statistics.median(load))} "
            f"| {ms(statistics.median(prep))} |"
        )

    lines = [
        f"Map loading and planner preparation (median of {repeats}):",
        "",
        "| map | grid | load ms | planner preparation ms |",
        "| --- | --- | ---: | ---: |",
        row("glassgarden.map (ARNL)", glassgarden, glassgarden_load, glassgarden_prep),
        row("willow.yaml (map_server)", willow, willow_load, willow_prep),
    ]
    return lines, glassgarden, glassgarden_prep


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="loads per map (default 5)")
    parser.add_argument("--write", action="store_true", help=f"also write {REPORT.name}")
    args = parser.parse_args()

    load_lines, glassgarden, _ = load_section(args.repeats)
    planner = RoutePlanner(glassgarden)
    planner.plan(glassgarden.poses[0], glassgarden.poses[1])  # warm-up
    found, refused, routes = plan_all_pairs(planner)
    places: list[NamedPose] = list(glassgarden.poses)
    waypoints = [len(route.waypoints) for route in routes.values()]
    lines = [
        "# Planner benchmark",
        "",
        f"Machine: {machine_line()}.",
        "Run: `.venv/bin/python benchmarks/bench_planner.py`.",
        "",
        *load_lines,
        "",
        f"Planning with pyastar2d between every ordered pair of Glassgården's {len(places)} named places "
        f"(goals, dock, robot homes) at 0.05 m, robot radius {planner.robot_radius} m. Pairs on different "
        "floors (the map's keep-out zones separate them) are refused with PlanningError before any search:",
        "",
        "| plans | p50 ms | p95 ms | max ms | count |",
        "| --- | ---: | ---: | ---: | ---: |",
        stats_row("route found", found),
        stats_row("refused (enclosed)", refused),
        stats_row("all", found + refused),
        "",
        f"Waypoints per route after pulling taut: mean {statistics.fmean(waypoints):.1f}, max {max(waypoints)}.",
        *mcp_reference(planner, routes),
        "",
        "Why pyastar2d: its A* (C++) stops at the goal and is guided by a heuristic, so it meets the "
        "50 ms p95 target on the full 0.05 m grid with no per-goal precomputation. MCP_Geometric is a "
        "Dijkstra that spreads in every direction until it reaches the goal, too slow here at p95. "
        "pyastar2d counts a diagonal step like a straight one, so its grid path may pass a speck of "
        "scan noise on the longer side; pulling the path taut removes the zig-zags but not that choice, "
        "which is what the worst length ratio above measures.",
        "",
    ]
    text = "\n".join(lines)
    print(text)
    if args.write:
        REPORT.write_text(text, encoding="utf-8")
        print(f"wrote {REPORT}")


if __name__ == "__main__":
    main()
