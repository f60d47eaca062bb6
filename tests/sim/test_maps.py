"""Map loaders: the real Glassgården (ARNL) and Willow (map_server) maps, the shipped campus map, bad files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cyborg.errors import MapError
from cyborg.maps import (
    Cell,
    OccupancyMap,
    Point,
    default_map_path,
    load_arnl_map,
    load_map,
    load_map_server,
    read_pgm,
    segment_cells,
)
from tests.support.paths import GLASSGARDEN, MAPS

WILLOW = MAPS / "willow.yaml"


@pytest.fixture(scope="module")
def glassgarden() -> OccupancyMap:
    return load_arnl_map(GLASSGARDEN)


def write_arnl(tmp_path: Path, body: str, name: str = "test.map") -> Path:
    path = tmp_path / name
    path.write_text("2D-Map\n" + body, encoding="utf-8")
    return path


# --- Glassgården --------------------------------------------------------------------------------------


def test_glassgarden_has_all_its_named_places(glassgarden: OccupancyMap) -> None:
    kinds = [pose.kind for pose in glassgarden.poses]
    assert kinds.count("GoalWithHeading") == 13
    assert kinds.count("Goal") == 5
    assert kinds.count("Dock") == 1
    assert kinds.count("RobotHome") == 2
    assert len({pose.name for pose in glassgarden.poses}) == len(glassgarden.poses) == 21


@pytest.mark.parametrize(
    ("name", "x", "y", "heading_deg"),
    [
        ("cafeteria", -33.075, -55.776, -16.8),
        ("el6", -30.397, -12.826, 106.4),
        ("info", -33.505, 1.139, -1.6),
        ("entrance2", -18.246, -65.898, 17.8),
    ],
)
def test_glassgarden_goals_in_metres_and_radians(
    glassgarden: OccupancyMap, name: str, x: float, y: float, heading_deg: float
) -> None:
    pose = glassgarden.pose(name)
    assert (pose.x, pose.y) == pytest.approx((x, y))
    assert pose.theta == pytest.approx(math.radians(heading_deg))
    assert pose.kind == "GoalWithHeading"
    assert glassgarden.contains(pose.x, pose.y)
    assert glassgarden.grid[glassgarden.world_to_cell(pose.x, pose.y)] == Cell.FREE


def test_plain_goal_ignores_theta_and_keeps_description(glassgarden: OccupancyMap) -> None:
    assert glassgarden.pose("hallway1").theta == 0.0
    assert glassgarden.pose("cafeteria").description == "This is the cafeteria."
    assert glassgarden.pose("cafeteria").source.endswith("line 33")


def test_unnamed_robot_homes_get_unique_names_and_rectangle_home_its_centre(
    glassgarden: OccupancyMap,
) -> None:
    rectangle_home = glassgarden.pose("robot home")
    assert (rectangle_home.x, rectangle_home.y) == pytest.approx(
        ((-35.270 - 25.533) / 2, (5.656 + 11.953) / 2)
    )
    assert glassgarden.pose("robot home 2").position == pytest.approx((-31.289, 10.208))
    assert glassgarden.pose("Charger").kind == "Dock"


def test_unknown_place_names_the_known_ones(glassgarden: OccupancyMap) -> None:
    with pytest.raises(MapError, match=r"no place named 'kitchen'.*cafeteria"):
        glassgarden.pose("kitchen")


def test_glassgarden_bounds_come_from_the_data_not_the_header(glassgarden: OccupancyMap) -> None:
    # The header's MinPos says y >= -88.14 m, but a wall line reaches -90.278 m.
    assert glassgarden.contains(-37.0, -90.27)
    assert glassgarden.grid[glassgarden.world_to_cell(-37.0, -90.276)] == Cell.OCCUPIED
    assert glassgarden.grid[glassgarden.world_to_cell(-41.36, 1.46)] == Cell.OCCUPIED  # first scan point
    assert glassgarden.origin[0] == pytest.approx(-41.36 - 0.5)
    assert glassgarden.resolution == 0.05
    width, height = glassgarden.size_m
    assert width == pytest.approx(6.2 + 41.36 + 1.0, abs=0.05)
    assert height == pytest.approx(12.56 + 90.278 + 1.0, abs=0.05)


def test_wall_lines_are_rasterised_without_gaps(glassgarden: OccupancyMap) -> None:
    # LINES: -39981 -90275 -35580 -90278, a 4.4 m wall.
    rows, cols = segment_cells(
        glassgarden.grid_coordinates((-39.981, -90.275)), glassgarden.grid_coordinates((-35.58, -90.278))
    )
    assert len(rows) >= 4.4 / 0.05
    assert (glassgarden.grid[rows, cols] == Cell.OCCUPIED).all()


def test_glassgarden_keep_out_zones_rotate_about_the_map_origin(glassgarden: OccupancyMap) -> None:
    assert len(glassgarden.keep_out) == 20
    # Line 25: ForbiddenArea 0 0 90 ... -67552 5362 -55700 13464, turned 90 degrees about (0, 0).
    zone = next(z for z in glassgarden.keep_out if z.source.endswith("line 25"))
    xs = sorted(round(c[0], 3) for c in zone.corners)
    ys = sorted(round(c[1], 3) for c in zone.corners)
    assert (xs[0], xs[-1]) == (-13.464, -5.362)
    assert (ys[0], ys[-1]) == (-67.552, -55.7)
    # Line 36 has THETA 0: the rectangle as written.
    plain = next(z for z in glassgarden.keep_out if z.source.endswith("line 36"))
    assert set(plain.corners) == {
        (-30.536, -48.965),
        (-23.02, -48.965),
        (-23.02, -40.247),
        (-30.536, -40.247),
    }


def test_keep_out_mask_covers_the_zone(glassgarden: OccupancyMap) -> None:
    zone = next(z for z in glassgarden.keep_out if z.source.endswith("line 36"))
    mask = glassgarden.keep_out_mask([zone])
    assert mask[glassgarden.world_to_cell(-26.0, -45.0)]
    assert not mask[glassgarden.world_to_cell(-26.0, -50.0)]
    expected_cells = (7.516 * 8.718) / 0.05**2
    assert mask.sum() == pytest.approx(expected_cells, rel=0.03)


# --- Willow (map_server) ---------------------------------------------------------------------------


def test_willow_size_resolution_and_cells() -> None:
    willow = load_map_server(WILLOW)
    assert willow.shape == (608, 566)
    assert willow.resolution == pytest.approx(0.1)
    assert willow.origin == (0.0, 0.0)
    assert willow.size_m == pytest.approx((56.6, 60.8))
    counts = np.bincount(willow.grid.ravel(), minlength=3)
    assert counts.sum() == 608 * 566
    assert counts[Cell.FREE] > 100_000
    assert counts[Cell.OCCUPIED] > 0
    assert counts[Cell.UNKNOWN] > counts[Cell.FREE]


def test_willow_row_zero_is_the_bottom_of_the_image() -> None:
    willow = load_map_server(WILLOW)
    image = read_pgm(MAPS / "willow.pgm")
    light = image > 1 - 0.196  # free_thresh of willow.yaml, on brightness
    free = willow.grid == Cell.FREE
    assert np.array_equal(free, light[::-1])
    assert not np.array_equal(free, light)


def write_map_server(tmp_path: Path, pgm: bytes, yaml_text: str) -> Path:
    (tmp_path / "tiny.pgm").write_bytes(pgm)
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml_text, encoding="utf-8")
    return path


def test_map_server_trinary_thresholds_negate_and_origin(tmp_path: Path) -> None:
    # Plain PGM with a comment; top row: black, grey, white.
    pgm = b"P2\n# made by hand\n3 2\n255\n0 128 255\n255 255 255\n"
    yaml_text = "image: tiny.pgm\nresolution: 0.5\norigin: [-1.0, 2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    tiny = load_map(write_map_server(tmp_path, pgm, yaml_text))
    assert tiny.grid[1].tolist() == [Cell.OCCUPIED, Cell.UNKNOWN, Cell.FREE]
    assert tiny.grid[0].tolist() == [Cell.FREE] * 3
    assert tiny.cell_to_world(1, 0) == (-0.75, 2.75)
    assert tiny.world_to_cell(-0.75, 2.75) == (1, 0)

    negated = load_map(write_map_server(tmp_path, pgm, yaml_text.replace("negate: 0", "negate: 1")))
    assert negated.grid[1].tolist() == [Cell.FREE, Cell.UNKNOWN, Cell.OCCUPIED]


def test_map_server_binary_16_bit_pgm(tmp_path: Path) -> None:
    pixels = np.array([[0, 65535], [65535, 0]], dtype=">u2")
    pgm = b"P5 2 2 65535\n" + pixels.tobytes()
    tiny = load_map(write_map_server(tmp_path, pgm, "image: tiny.pgm\nresolution: 1\norigin: [0, 0, 0]\n"))
    assert tiny.grid.tolist() == [[Cell.FREE, Cell.OCCUPIED], [Cell.OCCUPIED, Cell.FREE]]


@pytest.mark.parametrize(
    ("pgm", "yaml_text", "message"),
    [
        (b"P2 2 1 255\n0 0\n", "image: tiny.pgm\norigin: [0, 0, 0]\n", "missing resolution"),
        (b"P2 2 1 255\n0 0\n", "image: tiny.pgm\nresolution: 0.1\norigin: [0, 0, 0.5]\n", "rotated origin"),
        (
            b"P2 2 1 255\n0 0\n",
            "image: tiny.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nmode: raw\n",
            "mode 'raw'",
        ),
        (b"P5 4 4 255\n\x00\x00", "image: tiny.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", "truncated"),
        (b"GIF89a", "image: tiny.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", "not a PGM image"),
        (b"P2 2 1 255\n0 0\n", "image: tiny.pgm\nresolution: [oops\n", "not valid YAML"),
    ],
)
def test_bad_map_server_files_say_what_is_wrong(
    tmp_path: Path, pgm: bytes, yaml_text: str, message: str
) -> None:
    with pytest.raises(MapError, match=message):
        load_map_server(write_map_server(tmp_path, pgm, yaml_text))


# --- load_map and the shipped campus map ---------------------------------------------------------------


def test_load_map_dispatches_on_suffix(tmp_path: Path) -> None:
    assert load_map(WILLOW).resolution == pytest.approx(0.1)
    assert load_map(GLASSGARDEN, resolution=0.2).resolution == 0.2
    picture = tmp_path / "map.png"
    picture.write_bytes(b"\x89PNG")
    with pytest.raises(MapError, match=r"map\.png: unknown map format '\.png'.*fix"):
        load_map(picture)


def test_shipped_campus_map_has_its_places() -> None:
    campus = load_map(default_map_path())
    goals = {pose.name for pose in campus.poses if pose.kind == "GoalWithHeading"}
    assert goals == {
        "information desk",
        "cafeteria",
        "entrance",
        "entrance 2",
        "el5",
        "el6",
        "waiting area",
        "elevator",
    }
    home = next(pose for pose in campus.poses if pose.kind == "RobotHome")
    assert math.dist(home.position, campus.pose("information desk").position) < 3.0
    assert [zone.name for zone in campus.keep_out] == ["staircase"]
    assert campus.pose("elevator").theta == pytest.approx(math.pi / 2)


# --- ARNL details and malformed files -----------------------------------------------------------------


def test_keep_out_outside_the_scanned_area_is_kept_but_marks_nothing(tmp_path: Path) -> None:
    path = write_arnl(
        tmp_path,
        'Cairn: ForbiddenArea 0 0 0.000000 "" ICON "far away" 50000 50000 60000 60000\n'
        'Cairn: ForbiddenArea 0 0 0.000000 "" ICON "half in" -1000 -1000 1000 1000\n'
        'Cairn: ForbiddenLine 0 0 90.000000 "" ICON "rope" 250 -500 250 500\n'
        "LINES\n0 0 2000 0\nDATA\n0 2000\n2000 2000\n",
    )
    loaded = load_arnl_map(path, resolution=0.1)
    far, half, rope = loaded.keep_out
    assert far.name == "far away" and far.corners[0] == (50.0, 50.0)
    assert not loaded.keep_out_mask([far]).any()
    assert loaded.keep_out_mask([half])[loaded.world_to_cell(0.5, 0.5)]
    assert rope.is_line
    assert [(round(x, 9), round(y, 9)) for x, y in rope.corners] == [(0.5, 0.25), (-0.5, 0.25)]
    assert loaded.keep_out_mask([rope])[loaded.world_to_cell(0.0, 0.25)]
    assert loaded.size_m == pytest.approx((3.0, 3.0))


def test_unknown_lines_and_cairn_types_are_ignored(tmp_path: Path) -> None:
    path = write_arnl(
        tmp_path,
        "Whatever: 12\nthis line means nothing\n\n"
        'Cairn: Sector 0 0 0 "" ICON "zone" 0 0 1 1\n'
        'Cairn: Goal 500 500 45.0 "" ICON "spot"\n'
        "LINES\n\n0 0 1000 0\nDATA\n0 1000\n",
    )
    loaded = load_arnl_map(path, resolution=0.1)
    assert [pose.name for pose in loaded.poses] == ["spot"]
    assert loaded.pose("spot").position == (0.5, 0.5)
    assert loaded.keep_out == ()


@pytest.mark.parametrize(
    ("body", "line", "message"),
    [
        ("LINES\n0 0 1000 0\nDATA\n0 0\n10 abc\n", 6, "not a number"),
        ("LINES\n0 0 1000\nDATA\n0 0\n", 3, "LINES needs 4 numbers"),
        ("DATA\n0 0\n1 2 3\n", 4, "DATA needs 2 numbers"),
        ('Cairn: GoalWithHeading 1 two 0 "" ICON "x"\nDATA\n0 0\n', 2, "must be numbers"),
        ('Cairn: Goal 1 2 0 "unclosed ICON "x"\nDATA\n0 0\n', 2, "cannot split"),
        ('Cairn: ForbiddenArea 0 0 0 "" ICON ""\nDATA\n0 0\n', 2, "needs its 'x1 y1 x2 y2'"),
    ],
)
def test_malformed_map_names_file_and_line(tmp_path: Path, body: str, line: int, message: str) -> None:
    path = write_arnl(tmp_path, body, name="broken.map")
    with pytest.raises(MapError, match=rf"broken\.map: line {line}: .*{message}.*fix:"):
        load_arnl_map(path)


def test_a_file_that_is_not_a_map(tmp_path: Path) -> None:
    path = tmp_path / "notes.map"
    path.write_text("shopping list\neggs\n", encoding="utf-8")
    with pytest.raises(MapError, match=r"notes\.map: line 1: not an ARNL map.*fix:"):
        load_map(path)
    with pytest.raises(MapError, match=r"missing\.map: cannot read"):
        load_map(tmp_path / "missing.map")


def test_a_map_without_points_or_lines(tmp_path: Path) -> None:
    with pytest.raises(MapError, match="no scan points"):
        load_arnl_map(write_arnl(tmp_path, 'Cairn: Goal 0 0 0 "" ICON "lonely"\n'))


# --- grid geometry --------------------------------------------------------------------------------------

coordinate = st.floats(min_value=-20.0, max_value=20.0, allow_nan=False)


@given(x=coordinate, y=coordinate)
def test_world_cell_round_trip(x: float, y: float) -> None:
    grid = OccupancyMap(np.zeros((10, 10), dtype=np.uint8), resolution=0.25, origin=(-3.0, 4.0))
    row, col = grid.world_to_cell(x, y)
    centre_x, centre_y = grid.cell_to_world(row, col)
    assert abs(centre_x - x) <= 0.125 + 1e-9
    assert abs(centre_y - y) <= 0.125 + 1e-9
    assert grid.world_to_cell(centre_x, centre_y) == (row, col)


def touches(cell: tuple[int, int], start: Point, end: Point, slack: float = 1e-6) -> bool:
    """True when the segment meets the closed square of ``cell`` (row, col): slab clipping."""
    row, col = cell
    t_in, t_out = 0.0, 1.0
    for a, b, low in ((start[0], end[0], col), (start[1], end[1], row)):
        if a == b:
            if not low - slack <= a <= low + 1 + slack:
                return False
            continue
        t0, t1 = sorted(((low - slack - a) / (b - a), (low + 1 + slack - a) / (b - a)))
        t_in, t_out = max(t_in, t0), min(t_out, t1)
    return t_in <= t_out


@given(x0=coordinate, y0=coordinate, x1=coordinate, y1=coordinate)
def test_segment_cells_are_exactly_the_cells_the_segment_touches(
    x0: float, y0: float, x1: float, y1: float
) -> None:
    rows, cols = segment_cells((x0, y0), (x1, y1))
    found = set(zip(rows.tolist(), cols.tolist(), strict=True))
    for t in np.linspace(0.0, 1.0, 2001):
        x, y = x0 + t * (x1 - x0), y0 + t * (y1 - y0)
        assert (math.floor(y), math.floor(x)) in found
    assert all(touches(cell, (x0, y0), (x1, y1)) for cell in found)


def test_segment_through_a_corner_counts_the_cells_it_grazes() -> None:
    rows, cols = segment_cells((0.5, 0.5), (1.5, 1.5))
    assert set(zip(rows.tolist(), cols.tolist(), strict=True)) == {(0, 0), (0, 1), (1, 0), (1, 1)}
    rows, cols = segment_cells((0.5, 1.0), (2.5, 1.0))  # along a border: both rows
    assert set(zip(rows.tolist(), cols.tolist(), strict=True)) == {(r, c) for r in (0, 1) for c in (0, 1, 2)}


def test_a_map_without_goals_leaves_the_last_maps_places_behind(tmp_path: Path) -> None:
    """The same data folder, first the campus map, then Willow (no goals): no campus place is a target."""

    from cyborg.app.config import load_config, packaged_config
    from cyborg.app.robot import build_robot
    from cyborg.navigation.database import NavigationDatabase
    from cyborg.transport.clock import VirtualClock
    from cyborg.transport.embedded import EmbeddedTransport

    config = load_config(packaged_config("cyborg.yaml"))
    for map_path in (None, WILLOW):
        clock = VirtualClock()
        try:
            build_robot(config, EmbeddedTransport(clock), data_dir=tmp_path, seed=0, map_path=map_path)
        finally:
            clock.close()
        db = NavigationDatabase(tmp_path / "navigation.db")
        on_map = {place.name for place in db.locations_on_map()}
        if map_path is None:
            assert "cafeteria" in on_map
    assert db.current_map() == "willow" and on_map == set()


# --- the default world (issue 28: Glassgården, where the thesis ran) ------------------------------


def test_the_default_world_is_glassgarden_where_its_scan_is_found(tmp_path: Path) -> None:
    from cyborg.app.world import default_world, glassgarden_candidates

    assert default_world().name == "glassgarden.map"  # here: beside this checkout (../shared/maps)
    world = load_map(default_world())
    goals = {pose.name for pose in world.poses if pose.kind == "GoalWithHeading"}
    assert {
        "info",
        "cafeteria",
        "el6",
        "entrance2",
        "elevator1",
        "waitingarea",
    } <= goals  # the thesis's places
    mine = tmp_path / "maps"
    mine.mkdir()
    (mine / "glassgarden.map").write_bytes(GLASSGARDEN.read_bytes())
    env = {"CYBORG_MAPS": str(mine), "CYBORG_DATA_DIR": str(tmp_path / "data")}
    assert glassgarden_candidates(env)[:2] == [
        mine / "glassgarden.map",
        tmp_path / "data/maps/glassgarden.map",
    ]
    assert default_world(glassgarden_candidates(env)) == mine / "glassgarden.map"


def test_without_the_scan_the_robot_drives_on_the_campus_and_says_how_to_get_glassgarden(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from cyborg.app.world import default_world

    with caplog.at_level("WARNING", logger="cyborg.app.world"):
        assert default_world([tmp_path / "nowhere" / "glassgarden.map"]) == default_map_path()
    assert "the Glassgården map was not found" in caplog.text
    assert "thentnucyborg/CyborgRobot" in caplog.text and "--map FILE" in caplog.text


def test_a_scenario_runs_on_glassgarden_by_default(tmp_path: Path) -> None:
    from cyborg.app.config import load_config, packaged_config
    from cyborg.sim.scenario import run_scenario
    from cyborg.sim.script import parse_script

    records = run_scenario(load_config(packaged_config("cyborg.yaml")), parse_script("until: 2\n"))
    first = next(r for r in records if r["type"] == "pose")
    info = load_map(GLASSGARDEN).pose("info").position
    assert math.dist((first["x"], first["y"]), info) < 0.5  # it starts at Glassgården's information desk
