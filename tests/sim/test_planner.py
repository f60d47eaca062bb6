"""Route planner: detours around walls and keep-out zones, clearance, reasons for failure, real maps."""

from __future__ import annotations

import itertools
import math
import random
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy import ndimage

from cyborg.errors import PlanningError
from cyborg.maps import Cell, KeepOutZone, OccupancyMap, Point, default_map_path, load_map, segment_cells
from cyborg.sim.planner import Route, RoutePlanner, _close_diagonal_gaps, inflate
from tests.support.paths import GLASSGARDEN, MAPS

RESOLUTION = 0.05


def room(
    width_m: float = 10.0, height_m: float = 6.0, keep_out: tuple[KeepOutZone, ...] = ()
) -> OccupancyMap:
    """An empty room with walls one cell thick all round; origin at its lower-left corner."""
    grid = np.zeros((round(height_m / RESOLUTION), round(width_m / RESOLUTION)), dtype=np.uint8)
    grid[[0, -1], :] = Cell.OCCUPIED
    grid[:, [0, -1]] = Cell.OCCUPIED
    return OccupancyMap(grid, RESOLUTION, (0.0, 0.0), keep_out=keep_out, source="room")


def add_wall(grid: NDArray[np.uint8], x0: float, y0: float, x1: float, y1: float) -> None:
    """Fill the rectangle x0..x1, y0..y1 (metres) with wall."""
    rows = slice(round(y0 / RESOLUTION), round(y1 / RESOLUTION))
    cols = slice(round(x0 / RESOLUTION), round(x1 / RESOLUTION))
    grid[rows, cols] = Cell.OCCUPIED


def route_samples(route: Route, step: float = RESOLUTION / 10) -> NDArray[np.float64]:
    """Points every ``step`` metres along every leg of the route."""
    pieces = []
    for a, b in itertools.pairwise(route.waypoints):
        count = max(2, math.ceil(math.dist(a, b) / step) + 1)
        pieces.append(np.linspace(a, b, count))
    return np.concatenate(pieces)


def sample_cells(occupancy_map: OccupancyMap, points: NDArray[np.float64]) -> tuple[NDArray[np.intp], ...]:
    cols = np.floor((points[:, 0] - occupancy_map.origin[0]) / occupancy_map.resolution).astype(np.intp)
    rows = np.floor((points[:, 1] - occupancy_map.origin[1]) / occupancy_map.resolution).astype(np.intp)
    return rows, cols


def assert_valid_route(planner: RoutePlanner, route: Route, start: Point, goal: Point) -> None:
    assert route.waypoints[0] == pytest.approx(start)
    assert route.waypoints[-1] == pytest.approx(goal)
    legs = sum(math.dist(a, b) for a, b in itertools.pairwise(route.waypoints))
    assert route.length == pytest.approx(legs)
    assert route.length >= math.dist(start, goal) - 1e-9
    rows, cols = sample_cells(planner.map, route_samples(route))
    assert not planner.inflated[rows, cols].any(), "a leg of the route crosses an inflated obstacle"


# --- walls and keep-out zones ---------------------------------------------------------------------------


def test_open_room_gives_a_straight_route() -> None:
    planner = RoutePlanner(room())
    route = planner.plan((2.0, 3.0), (8.0, 1.0))
    assert route.waypoints == ((2.0, 3.0), (8.0, 1.0))
    assert route.length == pytest.approx(math.dist((2, 3), (8, 1)))


def test_route_goes_around_a_wall_in_between() -> None:
    hall = room()
    add_wall(hall.grid, 4.9, 0.0, 5.1, 4.5)  # wall from the floor up to y = 4.5, open above
    planner = RoutePlanner(hall)
    start, goal = (2.0, 1.0), (8.0, 1.0)
    route = planner.plan(start, goal)
    assert_valid_route(planner, route, start, goal)
    # The centre must pass above the wall's end plus the clearance: at least this long.
    over_the_top = (4.9 - planner.safety_distance, 4.5 + planner.safety_distance)
    assert route.length >= math.dist(start, over_the_top) + math.dist(over_the_top, goal) - 0.1
    assert route.length < 11.0
    assert max(y for _, y in route.waypoints) > 4.5
    assert len(route.waypoints) <= 10  # a few hug the rounded end of the wall


def test_the_search_weights_say_their_true_minimum() -> None:
    """pyastar2d refuses weights below 1; the planner's weights answer min() without reading the
    grid, which holds only when every cell is 1 or inf and one is 1."""
    hall = room()
    add_wall(hall.grid, 4.9, 0.0, 5.1, 4.5)
    planner = RoutePlanner(hall)
    planner.plan((2.0, 1.0), (8.0, 1.0))
    assert planner._weights is not None
    weights = planner._weights[1]
    plain = np.asarray(weights)
    assert set(np.unique(plain).tolist()) == {1.0, math.inf}
    assert weights.min() == plain.min() == 1.0
    assert weights.min(axis=0).tolist() == plain.min(axis=0).tolist()  # other reductions are real


def test_route_avoids_a_keep_out_zone_that_the_straight_line_crosses() -> None:
    pillar = KeepOutZone(((4.0, 1.5), (6.0, 1.5), (6.0, 4.5), (4.0, 4.5)), name="pillar")
    hall = room(keep_out=(pillar,))
    start, goal = (2.0, 3.0), (8.0, 3.0)
    planner = RoutePlanner(hall)
    route = planner.plan(start, goal)
    assert_valid_route(planner, route, start, goal)
    points = route_samples(route)
    outside_x = np.maximum(np.maximum(4.0 - points[:, 0], points[:, 0] - 6.0), 0.0)
    outside_y = np.maximum(np.maximum(1.5 - points[:, 1], points[:, 1] - 4.5), 0.0)
    assert np.hypot(outside_x, outside_y).min() >= planner.robot_radius
    assert route.length > 6.5

    ignoring_zones = RoutePlanner(hall, keep_out=[])
    assert ignoring_zones.plan(start, goal).length == pytest.approx(6.0)


def test_keep_out_line_blocks_like_a_wall() -> None:
    rope = KeepOutZone(((5.0, 0.0), (5.0, 6.0)), name="rope")
    planner = RoutePlanner(room(), keep_out=[rope])
    with pytest.raises(PlanningError, match="enclosed"):
        planner.plan((2.0, 3.0), (8.0, 3.0))


def test_robot_radius_decides_whether_a_doorway_is_passable() -> None:
    hall = room()
    add_wall(hall.grid, 4.9, 0.0, 5.1, 2.5)
    add_wall(hall.grid, 4.9, 3.5, 5.1, 6.0)  # a 1.0 m doorway at y 2.5..3.5
    start, goal = (2.0, 1.0), (8.0, 5.0)
    slim = RoutePlanner(hall, robot_radius=0.35)
    route = slim.plan(start, goal)
    assert_valid_route(slim, route, start, goal)
    wide = RoutePlanner(hall, robot_radius=0.6)
    with pytest.raises(PlanningError, match="enclosed"):
        wide.plan(start, goal)


def test_segment_on_the_map_edge_does_not_wrap_around() -> None:
    grid = np.zeros((20, 20), dtype=np.uint8)
    grid[:, -1] = Cell.OCCUPIED  # the far right column
    planner = RoutePlanner(OccupancyMap(grid, RESOLUTION, (0.0, 0.0)), robot_radius=0.0)
    assert planner.segment_is_free((0.0, 0.2), (0.0, 0.8))
    assert not planner.segment_is_free((0.2, 0.5), (0.99, 0.5))


# --- reasons when there is no route ---------------------------------------------------------------------


def test_goal_inside_or_next_to_a_wall() -> None:
    hall = room()
    add_wall(hall.grid, 4.9, 0.0, 5.1, 4.5)
    planner = RoutePlanner(hall)
    with pytest.raises(PlanningError, match=r"goal \(5\.0, 1\.0\) is inside a wall or within 0\.35 m of one"):
        planner.plan((2.0, 1.0), (5.0, 1.0))
    with pytest.raises(
        PlanningError, match=r"start \(5\.3, 1\.0\) is inside a wall or within 0\.35 m of one"
    ):
        planner.plan((5.3, 1.0), (2.0, 1.0))


def test_goal_inside_or_next_to_a_keep_out_zone() -> None:
    pillar = KeepOutZone(((4.0, 1.5), (6.0, 1.5), (6.0, 4.5), (4.0, 4.5)), name="pillar", source="test")
    planner = RoutePlanner(room(keep_out=(pillar,)))
    with pytest.raises(PlanningError, match=r"goal \(5\.0, 3\.0\) is inside keep-out zone 'pillar' \(test\)"):
        planner.plan((2.0, 3.0), (5.0, 3.0))
    with pytest.raises(PlanningError, match=r"goal \(6\.2, 3\.0\) is within 0\.35 m of a keep-out zone"):
        planner.plan((2.0, 3.0), (6.2, 3.0))


def test_goal_off_the_map() -> None:
    planner = RoutePlanner(room())
    with pytest.raises(
        PlanningError, match=r"goal \(12\.3, 4\.0\) is off the map, which spans x 0\.0\.\.10\.0 m"
    ):
        planner.plan((2.0, 3.0), (12.3, 4.0))


def test_goal_in_an_enclosed_box() -> None:
    hall = room()
    add_wall(hall.grid, 6.0, 1.0, 9.0, 1.1)
    add_wall(hall.grid, 6.0, 4.0, 9.0, 4.1)
    add_wall(hall.grid, 6.0, 1.0, 6.1, 4.1)
    add_wall(hall.grid, 8.9, 1.0, 9.0, 4.1)
    planner = RoutePlanner(hall)
    with pytest.raises(
        PlanningError, match=r"no route from \(2\.0, 3\.0\) to \(7\.5, 2\.5\): the goal .* is enclosed"
    ):
        planner.plan((2.0, 3.0), (7.5, 2.5))
    with pytest.raises(PlanningError, match=r"the start \(7\.5, 2\.5\) is enclosed"):
        planner.plan((7.5, 2.5), (2.0, 3.0))
    inside = planner.plan((6.8, 1.8), (8.2, 3.2))
    assert_valid_route(planner, inside, (6.8, 1.8), (8.2, 3.2))


def test_goal_in_unknown_space() -> None:
    hall = room()
    hall.grid[:, 150:] = Cell.UNKNOWN
    planner = RoutePlanner(hall)
    with pytest.raises(PlanningError, match=r"goal \(8\.0, 3\.0\) is in unmapped \(unknown\) space"):
        planner.plan((2.0, 3.0), (8.0, 3.0))


# --- wandering -------------------------------------------------------------------------------------------


def test_random_reachable_points_are_free_reachable_and_repeatable() -> None:
    hall = room()
    add_wall(hall.grid, 3.9, 0.0, 4.1, 6.0)  # two separate parts, the right one larger
    planner = RoutePlanner(hall)
    rng = random.Random(4)
    points = [planner.random_reachable_point(rng, near=(2.0, 3.0)) for _ in range(50)]
    assert all(planner.is_free(*p) and p[0] < 3.9 for p in points)
    for point in points[:5]:
        planner.plan((2.0, 3.0), point)
    again = random.Random(4)
    assert [planner.random_reachable_point(again, near=(2.0, 3.0)) for _ in range(50)] == points
    assert len(set(points)) > 40
    anywhere = [planner.random_reachable_point(rng) for _ in range(50)]
    assert all(planner.is_free(*p) and p[0] > 4.1 for p in anywhere)


# --- real maps -----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def glassgarden_planner() -> RoutePlanner:
    return RoutePlanner(load_map(GLASSGARDEN))


def specks(seed: int = 7, size: int = 200, density: float = 0.01) -> OccupancyMap:
    """A floor strewn with single blocked cells: sharp corners everywhere."""
    grid = np.where(np.random.default_rng(seed).random((size, size)) < density, Cell.OCCUPIED, Cell.FREE)
    return OccupancyMap(grid.astype(np.uint8), RESOLUTION, (0.0, 0.0), source="specks")


@pytest.mark.parametrize("where", ["glassgarden", "specks"])
def test_segment_checks_agree_with_the_cells_each_segment_touches(
    where: str, glassgarden_planner: RoutePlanner
) -> None:
    """segment_is_free answers most segments from points along them (issue 18); its answer must
    be the one the exact cells give: on segments in the open, across walls, and ending on or
    passing the corners of blocked cells (as the taut routes' legs do)."""
    planner = glassgarden_planner if where == "glassgarden" else RoutePlanner(specks(), robot_radius=0.0)
    rng = random.Random(18)
    height, width = planner.inflated.shape
    next_to_free = ndimage.binary_dilation(~planner.inflated, structure=np.ones((3, 3), dtype=bool))
    edge_rows, edge_cols = np.nonzero(planner.inflated & next_to_free)
    resolution, (left, bottom) = planner.map.resolution, planner.map.origin
    seen = {True: 0, False: 0}
    for case in range(4000):
        if case % 2:  # from nearby free space to a corner of a blocked cell next to it, or past it
            pick = rng.randrange(len(edge_rows))
            corner_col = int(edge_cols[pick]) + rng.choice([0, 1])
            corner_row = int(edge_rows[pick]) + rng.choice([0, 1])
            corner = (left + corner_col * resolution, bottom + corner_row * resolution)
            angle, length = rng.uniform(0, 2 * math.pi), rng.uniform(0.05, 3.0)
            start = (corner[0] + length * math.cos(angle), corner[1] + length * math.sin(angle))
            if not planner.is_free(*start):
                continue
            beyond = rng.choice([1.0, 1.5, 2.0, 3.0])
            end = (start[0] + beyond * (corner[0] - start[0]), start[1] + beyond * (corner[1] - start[1]))
        else:
            start = planner.random_reachable_point(rng)
            angle, length = rng.uniform(0, 2 * math.pi), rng.choice([0.03, 0.3, 3.0, 9.0])
            end = (start[0] + length * math.cos(angle), start[1] + length * math.sin(angle))
        if not planner.map.contains(*end):
            continue
        rows, cols = segment_cells(planner.map.grid_coordinates(start), planner.map.grid_coordinates(end))
        rows, cols = np.clip(rows, 0, height - 1), np.clip(cols, 0, width - 1)
        exact = not planner.inflated[rows, cols].any()
        assert planner.segment_is_free(start, end) is exact, (start, end)
        seen[exact] += 1
    assert min(seen.values()) > 300, seen


def test_glassgarden_every_pair_of_places_plans_or_says_why(glassgarden_planner: RoutePlanner) -> None:
    planner = glassgarden_planner
    keep_out = planner.map.keep_out_mask()
    routes, enclosed = 0, 0
    for start, goal in itertools.permutations(planner.map.poses, 2):
        try:
            route = planner.plan(start, goal)
        except PlanningError as error:
            assert "is enclosed" in str(error)
            enclosed += 1
            continue
        routes += 1
        assert_valid_route(planner, route, start.position, goal.position)
        assert not keep_out[sample_cells(planner.map, route_samples(route, step=0.01))].any()
    # The keep-out zones split the map in two: 15 places on one side, 6 on the other.
    assert (routes, enclosed) == (15 * 14 + 6 * 5, 21 * 20 - 15 * 14 - 6 * 5)


def test_glassgarden_route_bends_where_the_straight_line_is_blocked(
    glassgarden_planner: RoutePlanner,
) -> None:
    planner = glassgarden_planner
    start, goal = planner.map.pose("info"), planner.map.pose("cafeteria")
    assert not planner.segment_is_free(start.position, goal.position)
    route = planner.plan(start, goal)
    straight = math.dist(start.position, goal.position)
    assert straight < route.length < 1.3 * straight
    assert len(route.waypoints) > 2
    el6_route = planner.plan(planner.map.pose("el6"), planner.map.pose("entrance2"))
    assert el6_route.length > math.dist(
        planner.map.pose("el6").position, planner.map.pose("entrance2").position
    )


def test_glassgarden_named_goal_in_a_message(glassgarden_planner: RoutePlanner) -> None:
    with pytest.raises(
        PlanningError, match=r"no route from 'info' \(-33\.5, 1\.1\) to 'hallway1' \(1\.1, -6\.0\)"
    ):
        glassgarden_planner.plan(
            glassgarden_planner.map.pose("info"), glassgarden_planner.map.pose("hallway1")
        )


def test_campus_places_are_all_mutually_reachable_and_avoid_the_staircase() -> None:
    campus = load_map(default_map_path())
    planner = RoutePlanner(campus)
    staircase = campus.keep_out_mask()
    for start, goal in itertools.permutations(campus.poses, 2):
        route = planner.plan(start, goal)
        assert_valid_route(planner, route, start.position, goal.position)
        assert not staircase[sample_cells(campus, route_samples(route, step=0.01))].any()


def test_willow_plans_between_random_points() -> None:
    planner = RoutePlanner(load_map(MAPS / "willow.yaml"))
    rng = random.Random(1)
    for _ in range(10):
        start = planner.random_reachable_point(rng)
        goal = planner.random_reachable_point(rng, near=start)
        route = planner.plan(start, goal)
        assert_valid_route(planner, route, start, goal)


# --- inflation and free areas: the same cells as the distance transform, in less memory --------------------


def inflated_by_distance_transform(
    blocked: NDArray[np.bool_], robot_radius: float, resolution: float
) -> NDArray[np.bool_]:
    """The planner's inflation up to commit 0d97fce: scipy's exact Euclidean distance transform."""
    if not blocked.any():
        return np.zeros_like(blocked)
    clearance = ndimage.distance_transform_edt(~blocked) * resolution
    return np.asarray(clearance < robot_radius + resolution / 2)


@pytest.mark.parametrize("map_path", [default_map_path(), GLASSGARDEN, MAPS / "willow.yaml"])
def test_inflation_is_the_distance_transforms_on_the_real_maps(map_path: Path) -> None:
    occupancy_map = load_map(map_path)
    blocked = occupancy_map.blocked | occupancy_map.keep_out_mask()
    for robot_radius in (0.0, 0.1, 0.275, 0.35, 0.5):
        expected = inflated_by_distance_transform(blocked, robot_radius, occupancy_map.resolution)
        got = inflate(blocked, robot_radius, occupancy_map.resolution)
        assert np.array_equal(got, expected), f"{map_path.name}, robot_radius {robot_radius}"
    expected = inflated_by_distance_transform(blocked, 0.35, occupancy_map.resolution)
    assert np.array_equal(RoutePlanner(occupancy_map).inflated, _close_diagonal_gaps(expected))


@pytest.mark.parametrize("resolution", [0.025, 0.05, 0.07, 0.1, 0.3])
def test_inflation_is_the_distance_transforms_on_random_specks(resolution: float) -> None:
    rng = np.random.default_rng(round(resolution * 1000))
    blocked = rng.random((120, 90)) < 0.01
    blocked[0, 5] = blocked[-1, -3] = blocked[40, 0] = True  # on the edges: beyond them counts as free
    for robot_radius in (0.0, 0.05, 0.12, 0.35, 0.6):
        assert np.array_equal(
            inflate(blocked, robot_radius, resolution),
            inflated_by_distance_transform(blocked, robot_radius, resolution),
        ), f"resolution {resolution}, robot_radius {robot_radius}"
    assert not inflate(np.zeros((4, 5), dtype=bool), 0.35, resolution).any()


def test_more_than_255_free_areas_get_wider_labels() -> None:
    grid = np.full((41, 41), Cell.OCCUPIED, dtype=np.uint8)
    grid[1::2, 1::2] = Cell.FREE  # 400 single free cells, no two touching even at a corner
    planner = RoutePlanner(OccupancyMap(grid, 1.0, (0.0, 0.0), source="pockets"), robot_radius=0.0)
    labels, count = ndimage.label(~planner.inflated, structure=np.ones((3, 3), dtype=bool))
    assert count == 400
    assert planner._components.dtype == np.uint16
    assert np.array_equal(planner._components, labels)
    assert planner._component_sizes.tolist() == [0] + [1] * 400
    assert planner.plan((1.5, 1.5), (1.5, 1.5)).length == 0
    with pytest.raises(PlanningError, match="is enclosed"):
        planner.plan((1.5, 1.5), (3.5, 1.5))
    assert planner.random_reachable_point(random.Random(1), near=(5.5, 7.5)) == (5.5, 7.5)
