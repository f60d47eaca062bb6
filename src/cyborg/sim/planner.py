"""Route planning for the simulated robot base on an :class:`~cyborg.maps.OccupancyMap`.

Part of the simulation layer, between the map (:mod:`cyborg.maps`) and the
simulated base that drives along the result. At construction the planner grows
every wall and keep-out zone by the robot's radius and labels the connected
free areas; a query then asks ``pyastar2d`` (A* in C++) for a grid path and
pulls it taut into a few straight, collision-free legs. Pure: no I/O, no clock.

Memory: the planner keeps two grids of one byte a cell, ``inflated``
and the free-area labels (two bytes a cell beyond 255 areas). Inflating is a
boolean dilation by a disc (a few shifted ORs, no distance transform), and the
A* weights, cut to the free area's bounding box, are kept for the area searched last only
(making them again for every search would cost about a quarter of its time; the peak is the same).
"""

from __future__ import annotations

import itertools
import math
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from cyborg.errors import InvalidValueError, PlanningError
from cyborg.maps import Cell, KeepOutZone, NamedPose, OccupancyMap, Point, segment_cells
from cyborg.sim.grid_search import search_area, search_weights

Location = Point | NamedPose
"""Where a route starts or ends: a world point in metres, or a named pose from the map."""

_EIGHT_NEIGHBOURS = np.ones((3, 3), dtype=bool)


@dataclass(frozen=True)
class Route:
    """A collision-free route: straight legs between ``waypoints`` (metres), start and goal included."""

    waypoints: tuple[Point, ...]
    length: float

    @staticmethod
    def through(waypoints: Sequence[Point]) -> Route:
        return Route(tuple(waypoints), sum(math.dist(a, b) for a, b in itertools.pairwise(waypoints)))


@dataclass(frozen=True)
class AreaSearch:
    """One A* search of the planner: its free area (whose :meth:`RoutePlanner.area_weights` it
    runs on) and its two cells in the area's box, whose corner is ``offset`` on the map's grid."""

    area: int
    start: tuple[int, int]
    goal: tuple[int, int]
    offset: tuple[int, int]


SearchedPaths = Callable[[AreaSearch], "NDArray[np.int32] | None"]
"""Where :meth:`RoutePlanner.plan` looks for a search made already (in box cells), before searching."""


class RoutePlanner:
    """Short collision-free routes for a round robot of ``robot_radius`` metres.

    A route is the A* grid path (diagonal steps cost as much as straight ones)
    pulled taut; on Glassgården it is on average 0.2 % and at worst 11 % longer
    than a true-Euclidean grid search would give (docs/benchmarks-history.md, "Route planning on the real
    Glassgården map").

    ``keep_out`` replaces the map's own keep-out zones when given. The robot's
    centre stays more than ``robot_radius`` (plus half a cell, for the cells'
    own size) from every wall, unknown cell and keep-out zone.
    """

    def __init__(
        self,
        occupancy_map: OccupancyMap,
        robot_radius: float = 0.35,
        keep_out: Sequence[KeepOutZone] | None = None,
    ) -> None:
        if robot_radius < 0:
            raise InvalidValueError(f"robot_radius must be >= 0 m, got {robot_radius}")
        self.map = occupancy_map
        self.robot_radius = robot_radius
        self.keep_out = tuple(occupancy_map.keep_out if keep_out is None else keep_out)
        blocked = occupancy_map.blocked
        blocked |= occupancy_map.keep_out_mask(self.keep_out)
        self.inflated: NDArray[np.bool_] = _close_diagonal_gaps(
            inflate(blocked, robot_radius, occupancy_map.resolution)
        )
        """True where the robot's centre may not be."""
        del blocked
        self._components, count = _label_free_areas(self.inflated)
        self._component_sizes = _label_sizes(self._components, count)
        self._component_sizes[0] = 0  # label 0 is the blocked cells
        self._component_boxes: list[tuple[slice, slice] | None] = [
            None,
            *ndimage.find_objects(self._components),
        ]
        self._row_counts: dict[int, NDArray[np.int64]] = {}
        """Per free area: how many of its cells lie in rows before each row (for random points)."""
        self._weights: tuple[int, NDArray[np.float32]] | None = None
        """The search weights of the free area searched last (a robot keeps to one area)."""
        self._near_blocked = _near_cells_bits(self.inflated)
        """Inflated cells and their eight neighbours, as bits (a quick answer for segment checks)."""

    @property
    def safety_distance(self) -> float:
        """How far (m) the robot's centre keeps from a wall cell's centre."""
        return self.robot_radius + self.map.resolution / 2

    def is_free(self, x: float, y: float) -> bool:
        """True when the robot may stand with its centre at (x, y)."""
        row, col = self.map.world_to_cell(x, y)
        return self.map.contains(x, y) and not self.inflated[row, col]

    def segment_is_free(self, start: Point, end: Point) -> bool:
        """True when the robot can drive straight from ``start`` to ``end`` (metres)."""
        if not (self.map.contains(*start) and self.map.contains(*end)):
            return False
        (c0, r0), (c1, r1) = self.map.grid_coordinates(start), self.map.grid_coordinates(end)
        # The cell of the middle is one of the segment's cells: blocked there is blocked, without
        # the cut points (half of the checks while pulling a route taut end here).
        row, col = math.floor((r0 + r1) / 2), math.floor((c0 + c1) / 2)
        if (
            0 <= row < self.inflated.shape[0]
            and 0 <= col < self.inflated.shape[1]
            and self.inflated[row, col]
        ):
            return False
        # Points every half cell or less along the segment. One well inside a blocked cell (more
        # than 1e-6 from its borders, where segment_cells decides by a hair) means blocked. Every
        # cell the segment touches is a point's cell or next to one, so when no point's cell is
        # next to a blocked cell the segment is free. Otherwise (near a wall) the exact cells decide.
        count = math.ceil(2 * math.hypot(c1 - c0, r1 - r0)) + 2
        t = np.arange(count) / (count - 1)
        along_rows, along_cols = r0 + t * (r1 - r0), c0 + t * (c1 - c0)
        rows = np.minimum(along_rows.astype(np.intp), self.inflated.shape[0] - 1)
        cols = np.minimum(along_cols.astype(np.intp), self.inflated.shape[1] - 1)
        for hit in np.flatnonzero(self.inflated[rows, cols]).tolist():
            if _well_inside(float(along_rows[hit])) and _well_inside(float(along_cols[hit])):
                return False
        if not (self._near_blocked[rows, cols >> 3] & (128 >> (cols & 7))).any():
            return True
        rows, cols = segment_cells((c0, r0), (c1, r1))
        # a point on the map's outer edge (np.clip's wrapper costs more than the two ufuncs)
        rows = np.minimum(np.maximum(rows, 0), self.inflated.shape[0] - 1)
        cols = np.minimum(np.maximum(cols, 0), self.inflated.shape[1] - 1)
        return not self.inflated[rows, cols].any()

    def plan(self, start: Location, goal: Location, searched: SearchedPaths | None = None) -> Route:
        """A short collision-free route from ``start`` to ``goal``; PlanningError saying why if there is none.

        ``searched`` gives the grid path of an :class:`AreaSearch` made already (by
        :func:`search_area` on another process), or None to search here; the route is the same.
        """
        start_point, goal_point = _point(start), _point(goal)
        start_cell = self._check_endpoint("start", start)
        goal_cell = self._check_endpoint("goal", goal)
        self._check_connected(start, start_cell, goal, goal_cell)
        if start_cell == goal_cell:
            return Route.through([start_point, goal_point])
        path = self._search(start_cell, goal_cell, searched)
        if path is None:  # cannot happen after _check_connected, unless the library disagrees with it
            raise PlanningError(
                f"no route from {_describe(start)} to {_describe(goal)}: the search found none"
            )
        return Route.through(self._pull_taut(start_point, self._without_corner_cuts(path), goal_point))

    def nearest_free_point(self, location: Location) -> Point | None:
        """The centre of the free cell nearest ``location`` (on the map), or None if the map has none."""
        x, y = _point(location)
        rows, cols = self.inflated.shape
        row, col = self.map.world_to_cell(
            min(max(x, self.map.origin[0]), self.map.origin[0] + self.map.size_m[0]),
            min(max(y, self.map.origin[1]), self.map.origin[1] + self.map.size_m[1]),
        )
        row, col = min(max(row, 0), rows - 1), min(max(col, 0), cols - 1)
        for reach in range(max(rows, cols)):  # squares of growing size: the first free cells are near
            top, left = max(0, row - reach), max(0, col - reach)
            window = self.inflated[top : row + reach + 1, left : col + reach + 1]
            free = np.argwhere(~window)
            if len(free):
                distances = (free[:, 0] + top - row) ** 2 + (free[:, 1] + left - col) ** 2
                best = free[int(distances.argmin())]
                return self.map.cell_to_world(int(best[0]) + top, int(best[1]) + left)
        return None

    def random_reachable_point(self, rng: random.Random, near: Location | None = None) -> Point:
        """A random free point (cell centre) reachable from ``near``, or in the largest free area.

        Deterministic for a given ``rng`` state; PlanningError if the map has no free space.
        """
        if near is None:
            component = self._largest_component()
        else:
            component = int(self._components[self._check_endpoint("start", near)])
        if component not in self._row_counts:
            in_rows = np.count_nonzero(self._components == component, axis=1)
            self._row_counts[component] = np.concatenate([[0], np.cumsum(in_rows)])
        before = self._row_counts[component]
        index = rng.randrange(int(before[-1]))  # the index-th cell of the area in row-major order
        row = int(np.searchsorted(before, index, side="right")) - 1
        col = int(np.flatnonzero(self._components[row] == component)[index - before[row]])
        return self.map.cell_to_world(row, col)

    def area_search(self, start: Location, goal: Location) -> AreaSearch | None:
        """The A* search :meth:`plan` would make between two locations, as another process can run
        it (:func:`search_area`), or None when there is none to make (an endpoint off the map or
        blocked, the two in different areas or in one cell)."""
        try:
            start_cell = self._check_endpoint("start", start)
            goal_cell = self._check_endpoint("goal", goal)
        except PlanningError:
            return None
        area = int(self._components[start_cell])
        if start_cell == goal_cell or area != int(self._components[goal_cell]):
            return None
        return self._area_search(start_cell, goal_cell)

    def area_blocked(self, area: int) -> NDArray[np.bool_]:
        """The inflated grid cut to a free area's box (a view): what its A* weights are made from."""
        box = self._component_boxes[area]
        assert box is not None  # an area of free cells has a box
        return self.inflated[box]

    def area_weights(self, area: int) -> NDArray[np.float32]:
        """The A* weights of a free area's box (:func:`search_weights` of :meth:`area_blocked`)."""
        if self._weights is None or self._weights[0] != area:
            self._weights = None  # the old area's weights go before the new ones are made
            self._weights = (area, search_weights(self.area_blocked(area)))
        return self._weights[1]

    def _area_search(self, start: tuple[int, int], goal: tuple[int, int]) -> AreaSearch:
        area = int(self._components[start])
        box = self._component_boxes[area]
        assert box is not None  # start is a free cell, so its area has a box
        top, left = box[0].start, box[1].start
        return AreaSearch(
            area, (start[0] - top, start[1] - left), (goal[0] - top, goal[1] - left), (top, left)
        )

    def _search(
        self, start: tuple[int, int], goal: tuple[int, int], searched: SearchedPaths | None = None
    ) -> NDArray[np.int32] | None:
        """pyastar2d's grid path between two cells of one free area, in the area's bounding box.

        The float32 weights (1 on free cells, inf elsewhere) cover the area's box: every cell next
        to the area is blocked or in it, so the box holds every cell the search can reach and the
        path is the same as on the whole grid. They are kept for the next search in the same area
        (the peak is the same: a search needs them anyway). ``searched`` may hold the path already
        (the same search, made ahead on another process).
        """
        search = self._area_search(start, goal)
        path = searched(search) if searched is not None else None
        if path is None:
            path = search_area(self.area_weights(search.area), search.start, search.goal)
        if path is None:
            return None
        return path + np.array(search.offset, dtype=path.dtype)

    def _largest_component(self) -> int:
        if not self._component_sizes.any():
            raise PlanningError(
                f"{self.map.source or 'map'}: no free space for a robot of radius {self.robot_radius} m; "
                "fix: use a smaller robot_radius or a map with open space"
            )
        return int(self._component_sizes.argmax())

    def _check_endpoint(self, role: str, location: Location) -> tuple[int, int]:
        """The free cell of a start or goal; PlanningError naming what is in the way otherwise."""
        x, y = _point(location)
        if not self.map.contains(x, y):
            width, height = self.map.size_m
            left, bottom = self.map.origin
            raise PlanningError(
                f"{role} {_describe(location)} is off the map, which spans "
                f"x {left:.1f}..{left + width:.1f} m and y {bottom:.1f}..{bottom + height:.1f} m"
            )
        cell = self.map.world_to_cell(x, y)
        if self.inflated[cell]:
            raise PlanningError(f"{role} {_describe(location)} is {self._obstacle_near(cell)}")
        return cell

    def _obstacle_near(self, cell: tuple[int, int]) -> str:
        """Say what keeps the robot's centre out of ``cell``: a wall, unknown space or a keep-out zone."""
        reach = math.ceil(self.safety_distance / self.map.resolution)
        row, col = cell
        rows = slice(max(0, row - reach), row + reach + 1)
        cols = slice(max(0, col - reach), col + reach + 1)
        margin = f"{self.robot_radius:.2f} m"
        keep_out = self.map.keep_out_mask(self.keep_out)  # only when saying why: not worth keeping
        if keep_out[cell]:
            return f"inside {self._zone_at(cell)}"
        if self.map.grid[cell] == Cell.OCCUPIED:
            return f"inside a wall or within {margin} of one"
        if self.map.grid[cell] == Cell.UNKNOWN:
            return "in unmapped (unknown) space"
        if (self.map.grid[rows, cols] == Cell.OCCUPIED).any():
            return f"inside a wall or within {margin} of one"
        if keep_out[rows, cols].any():
            return f"within {margin} of a keep-out zone"
        return f"within {margin} of unmapped (unknown) space"

    def _zone_at(self, cell: tuple[int, int]) -> str:
        for zone in self.keep_out:
            if self.map.keep_out_mask([zone])[cell]:
                return zone.describe()
        return "a keep-out zone"

    def _check_connected(
        self, start: Location, start_cell: tuple[int, int], goal: Location, goal_cell: tuple[int, int]
    ) -> None:
        start_area, goal_area = int(self._components[start_cell]), int(self._components[goal_cell])
        if start_area == goal_area:
            return
        sizes = self._component_sizes
        enclosed, other = ("goal", "start") if sizes[goal_area] <= sizes[start_area] else ("start", "goal")
        where = _describe(goal if enclosed == "goal" else start)
        raise PlanningError(
            f"no route from {_describe(start)} to {_describe(goal)}: the {enclosed} {where} is enclosed, "
            f"walls or keep-out zones (with {self.robot_radius:.2f} m clearance) cut it off from the {other}"
        )

    def _without_corner_cuts(self, path: NDArray[np.int32]) -> NDArray[np.int32]:
        """Route each diagonal step that grazes a blocked cell's corner through the free side cell."""
        here, there = path[:-1], path[1:]
        diagonal = np.all(here != there, axis=1)
        side_a = np.stack([here[:, 0], there[:, 1]], axis=1)
        side_b = np.stack([there[:, 0], here[:, 1]], axis=1)
        a_blocked = self.inflated[side_a[:, 0], side_a[:, 1]]
        b_blocked = self.inflated[side_b[:, 0], side_b[:, 1]]
        grazing = np.flatnonzero(diagonal & (a_blocked | b_blocked))
        detours = np.where(a_blocked[grazing, None], side_b[grazing], side_a[grazing])
        return np.insert(path, grazing + 1, detours, axis=0)

    def _pull_taut(self, start: Point, path: NDArray[np.int32], goal: Point) -> list[Point]:
        """Replace a cell path by the few waypoints where it must turn to stay collision-free."""
        corners = [self.map.cell_to_world(int(r), int(c)) for r, c in path[_turning_points(path)]]
        points = [start, *corners, goal]
        waypoints = [start]
        anchor = 0
        while anchor < len(points) - 1:
            anchor = self._furthest_in_sight(points, anchor)
            waypoints.append(points[anchor])
        return self._drop_needless(waypoints)

    def _furthest_in_sight(self, points: list[Point], anchor: int) -> int:
        """Index of a far point seen in a straight line from ``points[anchor]`` (at least the next one).

        Gallops ahead, then bisects: a few segment checks instead of one per point.
        """
        seen, step = anchor + 1, 1
        while seen < len(points) - 1:
            probe = min(anchor + 2 * step, len(points) - 1)
            if not self.segment_is_free(points[anchor], points[probe]):
                break
            seen, step = probe, 2 * step
        else:
            return seen
        blocked = probe
        while blocked - seen > 1:
            middle = (seen + blocked) // 2
            if self.segment_is_free(points[anchor], points[middle]):
                seen = middle
            else:
                blocked = middle
        return seen

    def _drop_needless(self, waypoints: list[Point]) -> list[Point]:
        """From each kept waypoint, go straight to the last one in sight (skipping detours around specks)."""
        kept = [waypoints[0]]
        index = 0
        while index < len(waypoints) - 1:
            index = next(
                later
                for later in range(len(waypoints) - 1, index, -1)
                if later == index + 1 or self.segment_is_free(waypoints[index], waypoints[later])
            )
            kept.append(waypoints[index])
        return kept


def _well_inside(coordinate: float) -> bool:
    """True when a grid coordinate is more than 1e-6 from a cell border."""
    fraction = coordinate - math.floor(coordinate)
    return 1e-6 < fraction < 1 - 1e-6


def _near_cells_bits(mask: NDArray[np.bool_], band_rows: int = 256) -> NDArray[np.uint8]:
    """The mask's cells and their eight neighbours (a 3 x 3 dilation by ORs of shifts), as bits
    (``np.packbits`` along each row: cell (r, c) is bit ``7 - c % 8`` of byte ``[r, c // 8]``).

    Made a band of rows at a time, so it costs an eighth of a grid, not three grids.
    """
    height, width = mask.shape
    bits = np.empty((height, (width + 7) // 8), dtype=np.uint8)
    for top in range(0, height, band_rows):
        bottom = min(top + band_rows, height)
        low, high = max(top - 1, 0), min(bottom + 1, height)  # with the rows next to the band
        band = mask[low:high]
        tall = band.copy()
        tall[1:] |= band[:-1]
        tall[:-1] |= band[1:]
        broad = tall.copy()
        broad[:, 1:] |= tall[:, :-1]
        broad[:, :-1] |= tall[:, 1:]
        bits[top:bottom] = np.packbits(broad[top - low : bottom - low], axis=1)
    return bits


def inflate(blocked: NDArray[np.bool_], robot_radius: float, resolution: float) -> NDArray[np.bool_]:
    """True on every cell whose centre lies closer than ``robot_radius + resolution / 2`` to a blocked cell's.

    The same cells as ``distance_transform_edt(~blocked) * resolution < robot_radius + resolution / 2``
    (the float comparison included), without its float64 distances and index arrays: a dilation by
    the disc of offsets (dr, dc) with ``sqrt(dr**2 + dc**2) * resolution`` below that limit, made as
    one OR of row shifts per disc row, of the blocked cells widened sideways by that row's half-width.
    Cells beyond the grid's edge count as free. Memory: three boolean grids.
    """
    half_widths = _disc_half_widths(robot_radius + resolution / 2, resolution)
    inflated = np.zeros_like(blocked, dtype=bool)
    if not blocked.any():
        return inflated
    widened = blocked.copy()  # blocked, widened sideways by `width` cells
    width = 0
    for row_offset in range(len(half_widths) - 1, -1, -1):  # outer rows are narrowest
        while width < half_widths[row_offset]:
            width += 1
            widened[:, width:] |= blocked[:, :-width]
            widened[:, :-width] |= blocked[:, width:]
        if row_offset == 0:
            inflated |= widened
        else:
            inflated[row_offset:] |= widened[:-row_offset]
            inflated[:-row_offset] |= widened[row_offset:]
    return inflated


def _disc_half_widths(limit: float, resolution: float) -> list[int]:
    """For each row offset dr = 0, 1, ...: the largest dc with ``sqrt(dr**2 + dc**2) * resolution < limit``.

    Computed as ``distance_transform_edt`` computes a distance (float64 sqrt of the integer sum of
    squares, times the resolution), so the comparison falls the same way on every offset.
    """
    reach = math.ceil(limit / resolution) + 1
    offsets = np.arange(reach + 1, dtype=np.float64)
    inside = np.sqrt(offsets[:, None] ** 2 + offsets[None, :] ** 2) * resolution < limit
    return [int(np.flatnonzero(row)[-1]) for row in inside if row[0]]


def _label_free_areas(inflated: NDArray[np.bool_]) -> tuple[NDArray[np.integer], int]:
    """The 8-connected free areas, labelled 1..count as uint8, uint16 beyond 255 areas, int32 beyond 65535."""
    free = ~inflated
    try:
        labels, count = ndimage.label(free, structure=_EIGHT_NEIGHBOURS, output=np.uint8)
    except RuntimeError:  # more than 255 areas
        labels, count = ndimage.label(free, structure=_EIGHT_NEIGHBOURS)
        if count <= np.iinfo(np.uint16).max:
            labels = labels.astype(np.uint16)
    return labels, int(count)


def _label_sizes(labels: NDArray[np.integer], count: int) -> NDArray[np.int64]:
    """Cells per label 0..count, counted a band of rows at a time (bincount widens to 8 bytes a cell)."""
    sizes = np.zeros(count + 1, dtype=np.int64)
    band = max(1, (1 << 18) // max(1, labels.shape[1]))
    for top in range(0, labels.shape[0], band):
        sizes += np.bincount(labels[top : top + band].ravel(), minlength=count + 1)
    return sizes


def _close_diagonal_gaps(blocked: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Block both free cells of every 2x2 square whose blocked cells touch only at a corner; in place.

    Free space then never narrows to a single corner point, so every diagonal
    step has at least one free side cell to go through instead.
    """
    while True:
        low_left, low_right = blocked[:-1, :-1], blocked[:-1, 1:]
        high_left, high_right = blocked[1:, :-1], blocked[1:, 1:]
        rising = low_left & high_right & ~low_right & ~high_left
        falling = low_right & high_left & ~low_left & ~high_right
        if not (rising.any() or falling.any()):
            return blocked
        low_right |= rising
        high_left |= rising
        low_left |= falling
        high_right |= falling


def _turning_points(path: NDArray[np.int32]) -> NDArray[np.bool_]:
    """True at the first and last cell of a path and wherever its direction changes."""
    steps = np.diff(path, axis=0)
    turns = np.any(steps[1:] != steps[:-1], axis=1)
    return np.concatenate([[True], turns, [True]])


def _point(location: Location) -> Point:
    return location.position if isinstance(location, NamedPose) else (float(location[0]), float(location[1]))


def _describe(location: Location) -> str:
    x, y = _point(location)
    name = f"{location.name!r} " if isinstance(location, NamedPose) else ""
    return f"{name}({x:.1f}, {y:.1f})"
