"""Write the package's default map, ``src/cyborg/data/maps/campus.map`` (ARNL format, mm and degrees).

A made-up campus building for the simulated robot base: an entrance hall with
the information desk, a long corridor, a cafeteria with tables, an elevator
alcove and two lecture-hall wings (EL5 north, EL6 south). Walls are LINES,
scan points are sampled along them (DATA), goals are GoalWithHeading cairns
and a staircase in the hall is a ForbiddenArea. Deterministic: the same file
every run.

Run: .venv/bin/python scripts/make_campus_map.py
"""

from __future__ import annotations

import math
import random
from pathlib import Path

Segment = tuple[float, float, float, float]
Gap = tuple[float, float]

OUTPUT = Path(__file__).resolve().parent.parent / "src" / "cyborg" / "data" / "maps" / "campus.map"
SCAN_SPACING_M = 0.25
SCAN_JITTER_M = 0.02

# name: (x m, y m, heading deg, description)
GOALS: dict[str, tuple[float, float, float, str]] = {
    "information desk": (-6.0, 5.5, -90.0, "The information desk in the entrance hall."),
    "entrance": (-12.0, 3.0, 0.0, "The main entrance."),
    "waiting area": (-10.5, -4.5, 45.0, "The waiting area by the main entrance."),
    "elevator": (13.5, 5.5, 90.0, "The elevator."),
    "el5": (30.0, 43.5, 90.0, "Lecture hall EL5."),
    "el6": (49.5, -34.0, -90.0, "Lecture hall EL6."),
    "cafeteria": (66.0, 2.0, 0.0, "The cafeteria."),
    "entrance 2": (79.5, 13.0, 0.0, "The second entrance, through the cafeteria."),
}
ROBOT_HOME = (-3.5, 5.5, -90.0)
STAIRCASE = (-7.0, -3.0, -3.0, 0.0)  # x1 y1 x2 y2, m


def wall(x1: float, y1: float, x2: float, y2: float, gaps: list[Gap] | None = None) -> list[Segment]:
    """An axis-parallel wall, cut open where ``gaps`` (from, to along the wall) are doorways."""
    horizontal = y1 == y2
    low, high = (min(x1, x2), max(x1, x2)) if horizontal else (min(y1, y2), max(y1, y2))
    pieces: list[Segment] = []
    cursor = low
    for gap_from, gap_to in sorted(gaps or []):
        if gap_from > cursor:
            pieces.append(_piece(horizontal, x1, y1, cursor, gap_from))
        cursor = max(cursor, gap_to)
    if cursor < high:
        pieces.append(_piece(horizontal, x1, y1, cursor, high))
    return pieces


def _piece(horizontal: bool, x: float, y: float, start: float, end: float) -> Segment:
    return (start, y, end, y) if horizontal else (x, start, x, end)


def room(x1: float, y1: float, x2: float, y2: float, doors: dict[str, list[Gap]]) -> list[Segment]:
    """Four walls; ``doors`` maps a side (south, north, west, east) to its doorways."""
    return [
        *wall(x1, y1, x2, y1, doors.get("south")),
        *wall(x1, y2, x2, y2, doors.get("north")),
        *wall(x1, y1, x1, y2, doors.get("west")),
        *wall(x2, y1, x2, y2, doors.get("east")),
    ]


def box(x: float, y: float, width: float, depth: float) -> list[Segment]:
    """A closed rectangle of furniture with its lower-left corner at (x, y)."""
    return room(x, y, x + width, y + depth, {})


def building() -> list[Segment]:
    walls = [
        *room(-14, -8, 0, 12, {"east": [(0, 4)]}),  # entrance hall
        *room(
            0,
            0,
            60,
            4,
            {"west": [(0, 4)], "east": [(0, 4)], "north": [(12, 15), (28, 31)], "south": [(48, 51)]},
        ),
        *room(12, 4, 15, 7, {"south": [(12, 15)]}),  # elevator alcove
        *room(28, 4, 31, 40, {"south": [(28, 31)], "north": [(28, 31)]}),  # corridor to EL5
        *room(20, 40, 40, 56, {"south": [(28, 31)]}),  # lecture hall EL5
        *room(48, -30, 51, 0, {"north": [(48, 51)], "south": [(48, 51)]}),  # corridor to EL6
        *room(40, -46, 60, -30, {"north": [(48, 51)]}),  # lecture hall EL6
        *room(60, -10, 82, 16, {"west": [(0, 4)]}),  # cafeteria
        *box(-8, 7, 4, 1),  # information desk counter
        *box(-13, -7.5, 4, 0.6),  # waiting-area bench
    ]
    for row_y in (47.0, 49.0, 51.0, 53.0):  # EL5 seat rows, aisles along both side walls
        walls.append((22.0, row_y, 38.0, row_y))
    for row_y in (-40.0, -42.0, -44.0):  # EL6 seat rows
        walls.append((42.0, row_y, 58.0, row_y))
    for table_x in (69.0, 73.5, 78.0):  # cafeteria tables, 1.2 m square, 3.3 m apart
        for table_y in (-6.0, -1.5, 7.0, 11.0):
            walls.extend(box(table_x, table_y, 1.2, 1.2))
    return walls


def scan_points(walls: list[Segment], rng: random.Random) -> list[tuple[int, int]]:
    """Points along every wall, as a laser scan of it would leave them (mm)."""
    points = set()
    for x1, y1, x2, y2 in walls:
        steps = max(1, math.ceil(math.dist((x1, y1), (x2, y2)) / SCAN_SPACING_M))
        for step in range(steps + 1):
            t = step / steps
            x = x1 + t * (x2 - x1) + rng.uniform(-SCAN_JITTER_M, SCAN_JITTER_M)
            y = y1 + t * (y2 - y1) + rng.uniform(-SCAN_JITTER_M, SCAN_JITTER_M)
            points.add((round(x * 1000), round(y * 1000)))
    return sorted(points)


def cairn_lines() -> list[str]:
    lines = []
    for name, (x, y, heading, description) in GOALS.items():
        lines.append(
            f'Cairn: GoalWithHeading {x * 1000:.0f} {y * 1000:.0f} {heading:.6f} "{description}" ICON "{name}"'
        )
    home_x, home_y, home_heading = ROBOT_HOME
    lines.append(
        f'Cairn: RobotHome {home_x * 1000:.0f} {home_y * 1000:.0f} {home_heading:.6f} "" ICON "home"'
    )
    corners = " ".join(f"{value * 1000:.0f}" for value in STAIRCASE)
    lines.append(f'Cairn: ForbiddenArea 0 0 0.000000 "" ICON "staircase" {corners}')
    return lines


def render(walls: list[Segment], points: list[tuple[int, int]]) -> str:
    wall_mm = [tuple(round(v * 1000) for v in segment) for segment in walls]
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    line_xs = [v for s in wall_mm for v in (s[0], s[2])]
    line_ys = [v for s in wall_mm for v in (s[1], s[3])]
    header = [
        "2D-Map",
        f"MinPos: {min(xs)} {min(ys)}",
        f"MaxPos: {max(xs)} {max(ys)}",
        f"NumPoints: {len(points)}",
        "PointsAreSorted: true",
        f"Resolution: {round(SCAN_SPACING_M * 1000)}",
        f"LineMinPos: {min(line_xs)} {min(line_ys)}",
        f"LineMaxPos: {max(line_xs)} {max(line_ys)}",
        f"NumLines: {len(wall_mm)}",
        'MapInfo: GoalType "Name=Goal" "Label=Goal" "NameRequired=1"',
        'MetaInfo: Note "Made-up campus building for the cyborg simulator; scripts/make_campus_map.py"',
        *cairn_lines(),
        "LINES",
        *(" ".join(str(v) for v in segment) for segment in wall_mm),
        "DATA",
        *(f"{x} {y}" for x, y in points),
    ]
    return "\n".join(header) + "\n"


def main() -> None:
    walls = building()
    text = render(walls, scan_points(walls, random.Random(2017)))
    OUTPUT.parent.mkdir(parents=True, exist_ok=True)
    OUTPUT.write_text(text, encoding="utf-8")
    print(f"wrote {OUTPUT} ({len(walls)} wall lines, {text.count(chr(10))} lines)")


if __name__ == "__main__":
    main()
