"""Maps for the simulated robot base: occupancy grid, named places and keep-out zones.

Part of the simulation layer. Reads the two map formats the Cyborg meets: the
ARNL/MobileRobots ``.map`` files its Pioneer LX base uses (Mapper3 output, in mm
and degrees) and ROS ``map_server`` maps (a PGM image plus a YAML file). Both
become one :class:`OccupancyMap`; route planning on top of it lives in
:mod:`cyborg.sim.planner`. Pure: the only I/O is reading the given files.
"""

from __future__ import annotations

import enum
import math
import re
import shlex
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from cyborg.configfile import describe_errors, load_yaml, read_text_file
from cyborg.errors import ConfigError, MapError
from cyborg.limits import MAX_MAP_CELLS

Point = tuple[float, float]

MM_PER_M = 1000.0
ARNL_MAP_MARGIN_M = 0.5
"""Free border added around an ARNL map's data so the edge cells stay plannable."""


class Cell(enum.IntEnum):
    """What one grid cell holds."""

    FREE = 0
    OCCUPIED = 1
    UNKNOWN = 2


@dataclass(frozen=True)
class NamedPose:
    """A named place on the map, in metres and radians.

    ``kind`` is what the map file called it (``GoalWithHeading``, ``Dock``, ...);
    ``source`` says where it came from (file and line), for error messages.
    """

    name: str
    x: float
    y: float
    theta: float
    kind: str = "Goal"
    description: str = ""
    source: str = ""

    @property
    def position(self) -> Point:
        return (self.x, self.y)


@dataclass(frozen=True)
class KeepOutZone:
    """An area the robot must not enter: a polygon, or a line when it has two corners."""

    corners: tuple[Point, ...]
    name: str = ""
    source: str = ""

    @property
    def is_line(self) -> bool:
        return len(self.corners) == 2

    def describe(self) -> str:
        label = f" {self.name!r}" if self.name else ""
        where = f" ({self.source})" if self.source else ""
        return f"keep-out {'line' if self.is_line else 'zone'}{label}{where}"


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """A 2-D grid of :class:`Cell` values, row 0 at the smallest y.

    ``origin`` is the world position (m) of the lower-left corner of cell (0, 0).
    """

    grid: NDArray[np.uint8]
    resolution: float
    origin: Point
    poses: tuple[NamedPose, ...] = ()
    keep_out: tuple[KeepOutZone, ...] = ()
    source: str = ""
    _poses_by_name: dict[str, NamedPose] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.grid.ndim != 2 or self.grid.size == 0:
            raise MapError(f"{self.source or 'map'}: the grid must be a non-empty 2-D array")
        if not self.resolution > 0:
            raise MapError(f"{self.source or 'map'}: resolution must be > 0 m/cell, got {self.resolution}")
        object.__setattr__(self, "_poses_by_name", {pose.name: pose for pose in self.poses})

    @property
    def shape(self) -> tuple[int, int]:
        rows, cols = self.grid.shape
        return (rows, cols)

    @property
    def size_m(self) -> Point:
        """Width (x) and height (y) in metres."""
        return (self.shape[1] * self.resolution, self.shape[0] * self.resolution)

    @property
    def blocked(self) -> NDArray[np.bool_]:
        """True where the robot may not be: walls and unknown space."""
        return np.asarray(self.grid != Cell.FREE)

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """The (row, col) of the cell holding world point (x, y); may be off the grid."""
        col = math.floor((x - self.origin[0]) / self.resolution)
        row = math.floor((y - self.origin[1]) / self.resolution)
        return (row, col)

    def cell_to_world(self, row: int, col: int) -> Point:
        """The world position of the centre of cell (row, col)."""
        return (
            self.origin[0] + (col + 0.5) * self.resolution,
            self.origin[1] + (row + 0.5) * self.resolution,
        )

    def contains(self, x: float, y: float) -> bool:
        row, col = self.world_to_cell(x, y)
        return 0 <= row < self.shape[0] and 0 <= col < self.shape[1]

    def pose(self, name: str) -> NamedPose:
        """The named pose ``name``; MapError listing the known names if there is none."""
        try:
            return self._poses_by_name[name]
        except KeyError:
            known = ", ".join(sorted(self._poses_by_name)) or "none"
            raise MapError(
                f"{self.source or 'map'}: no place named {name!r}; known places: {known}"
            ) from None

    def keep_out_mask(self, zones: Iterable[KeepOutZone] | None = None) -> NDArray[np.bool_]:
        """True on every cell touched by one of ``zones`` (default: the map's own)."""
        mask = np.zeros(self.shape, dtype=bool)
        for zone in self.keep_out if zones is None else zones:
            if zone.is_line:
                mark_segment(
                    mask, self.grid_coordinates(zone.corners[0]), self.grid_coordinates(zone.corners[1])
                )
            else:
                _fill_polygon(mask, [self.grid_coordinates(corner) for corner in zone.corners])
        return mask

    def grid_coordinates(self, point: Point) -> Point:
        """World metres -> continuous grid coordinates (col, row); cell (r, c) spans c..c+1, r..r+1."""
        return (
            (point[0] - self.origin[0]) / self.resolution,
            (point[1] - self.origin[1]) / self.resolution,
        )


_SEGMENT_ENDS = np.array([0.0, 1.0])
_FIRST = np.array([True])


def segment_cells(start: Point, end: Point) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Every cell (rows, cols) a segment touches, in continuous grid coordinates (col, row).

    The segment is cut at each cell border it crosses; each cut point and the
    middle of each piece names the cells it lies in. A point on a border lies
    in the cells on both sides of it (all four at a corner), so a segment that
    only grazes a cell still counts it. May repeat cells.
    """
    (x0, y0), (x1, y1) = start, end
    cuts = [_SEGMENT_ENDS]
    for a, b in ((x0, x1), (y0, y1)):
        if a != b:
            low, high = (a, b) if a < b else (b, a)
            borders = np.arange(math.floor(low) + 1, math.ceil(high), dtype=float)
            cuts.append((borders - a) / (b - a))
    # Rounding merges a corner's two crossings, which floating point would leave a hair apart.
    # (np.unique's own steps, without its wrapper: the route planner checks ~60,000 segments a day.)
    t = np.round(np.concatenate(cuts), 9)
    t.sort()
    t = t[np.concatenate((_FIRST, t[1:] != t[:-1]))]
    t = np.concatenate((t, (t[:-1] + t[1:]) / 2))
    # x and y in one array: half the numpy calls, the same numbers
    (cols, rows), (on_col_border, on_row_border) = _cells_touching(
        np.array([[x0], [y0]]) + t * np.array([[x1 - x0], [y1 - y0]])
    )
    return (
        np.concatenate([rows, rows - on_row_border, rows, rows - on_row_border]),
        np.concatenate([cols, cols, cols - on_col_border, cols - on_col_border]),
    )


def _cells_touching(values: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The cell index of each coordinate, and 1 where it sits on the border with the cell below."""
    nearest = np.round(values)
    on_border = np.abs(values - nearest) < 1e-9
    cells = np.where(on_border, nearest, np.floor(values)).astype(np.int64)
    return cells, on_border.astype(np.int64)


def mark_segment(mask: NDArray[np.bool_], start: Point, end: Point) -> None:
    """Set every on-grid cell of a segment (continuous grid coordinates) to True."""
    rows, cols = segment_cells(start, end)
    inside = (rows >= 0) & (rows < mask.shape[0]) & (cols >= 0) & (cols < mask.shape[1])
    mask[rows[inside], cols[inside]] = True


def _fill_polygon(mask: NDArray[np.bool_], corners: Sequence[Point]) -> None:
    """Set the cells whose centres lie inside the polygon, plus its outline, to True."""
    xs = np.array([c[0] for c in corners])
    ys = np.array([c[1] for c in corners])
    col_lo, col_hi = max(0, math.floor(xs.min())), min(mask.shape[1], math.ceil(xs.max()))
    row_lo, row_hi = max(0, math.floor(ys.min())), min(mask.shape[0], math.ceil(ys.max()))
    if col_lo >= col_hi or row_lo >= row_hi:
        return
    px, py = np.meshgrid(np.arange(col_lo, col_hi) + 0.5, np.arange(row_lo, row_hi) + 0.5)
    inside = np.zeros(px.shape, dtype=bool)
    for (ax, ay), (bx, by) in zip(corners, [*corners[1:], corners[0]], strict=True):
        if ay == by:
            continue
        crosses = (ay > py) != (by > py)
        x_at = ax + (py - ay) * (bx - ax) / (by - ay)
        inside ^= crosses & (px < x_at)
    mask[row_lo:row_hi, col_lo:col_hi] |= inside
    for a, b in zip(corners, [*corners[1:], corners[0]], strict=True):
        mark_segment(mask, a, b)


def default_map_path() -> Path:
    """The example campus map shipped with the package (``cyborg/data/maps/campus.map``).

    The robot's default world is Glassgården when its scan is found (:mod:`cyborg.app.world`).
    """
    return Path(str(resources.files("cyborg") / "data" / "maps" / "campus.map"))


def load_map(path: str | Path, *, resolution: float = 0.05) -> OccupancyMap:
    """Load a map, choosing the reader by suffix: ``.yaml``/``.yml`` (map_server) or ``.map`` (ARNL).

    ``resolution`` (m/cell) applies to ARNL maps only; a map_server map has its own.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml"):
        return load_map_server(path)
    if suffix == ".map":
        return load_arnl_map(path, resolution=resolution)
    raise MapError(
        f"{path}: unknown map format {suffix or '(no suffix)'!r}; "
        "fix: give an ARNL .map file or a ROS map_server .yaml file (which names its .pgm image)"
    )


# --- ROS map_server -----------------------------------------------------------------------------


def load_map_server(yaml_path: str | Path) -> OccupancyMap:
    """Load a ROS ``map_server`` map: the YAML description and the PGM image it names."""
    yaml_path = Path(yaml_path)
    info = _read_map_server_yaml(yaml_path)
    image_path = yaml_path.parent / str(info["image"])
    if image_path.suffix.lower() != ".pgm":
        raise MapError(
            f"{yaml_path}: image {image_path.name!r} is not a PGM file; "
            "fix: convert it to PGM (e.g. `convert map.png map.pgm`) and point 'image:' at it"
        )
    pixels = read_pgm(image_path)
    occupancy = pixels if info["negate"] else 1.0 - pixels
    grid = np.full(pixels.shape, Cell.UNKNOWN, dtype=np.uint8)
    grid[occupancy > info["occupied_thresh"]] = Cell.OCCUPIED
    grid[occupancy < info["free_thresh"]] = Cell.FREE
    return OccupancyMap(
        grid=np.ascontiguousarray(grid[::-1]),
        resolution=info["resolution"],
        origin=info["origin"],
        source=str(yaml_path),
    )


class MapServerFile(BaseModel):
    """The keys of a ROS ``map_server`` YAML file that the simulation reads (others are ignored)."""

    model_config = ConfigDict(extra="ignore", allow_inf_nan=False)

    image: str = Field(min_length=1, description="the PGM image, relative to this file", examples=["map.pgm"])
    resolution: float = Field(gt=0, description="metres per cell", examples=[0.05])
    origin: tuple[float, float] | tuple[float, float, float] = Field(
        description="x, y and yaw of the lower-left cell, in metres and radians",
        examples=[[-10.0, -10.0, 0.0]],
    )
    mode: str = Field("trinary", description="trinary or scale")
    negate: bool = Field(False, description="true if white is occupied")
    occupied_thresh: float = Field(0.65, ge=0, le=1, description="occupancy above which a cell is occupied")
    free_thresh: float = Field(0.196, ge=0, le=1, description="occupancy below which a cell is free")


def _read_map_server_yaml(yaml_path: Path) -> dict[str, Any]:
    try:
        raw = load_yaml(read_text_file(yaml_path), str(yaml_path))
    except OSError as error:
        raise MapError(
            f"{yaml_path}: cannot read the map file ({error.strerror}); fix: check the path"
        ) from None
    except ConfigError as error:
        raise MapError(str(error)) from None
    if not isinstance(raw, dict):
        raise MapError(f"{yaml_path}: expected a YAML mapping with 'image:', 'resolution:' and 'origin:'")
    missing = [key for key in ("image", "resolution", "origin") if key not in raw]
    if missing:
        raise MapError(f"{yaml_path}: missing {', '.join(missing)}; fix: add them (see ROS map_server docs)")
    mode = str(raw.get("mode", "trinary"))
    if mode not in ("trinary", "scale"):
        raise MapError(f"{yaml_path}: mode {mode!r} is not supported; fix: use mode 'trinary' or 'scale'")
    try:
        info = MapServerFile.model_validate(raw)
    except ValidationError as error:
        problems = describe_errors(error, MapServerFile, doc="the ROS map_server documentation")
        raise MapError(str(ConfigError(problems, source=str(yaml_path)))) from None
    if len(info.origin) == 3 and info.origin[2] != 0.0:
        raise MapError(
            f"{yaml_path}: a rotated origin (yaw {info.origin[2]}) is not supported; fix: set yaw to 0"
        )
    return {
        "image": info.image,
        "resolution": info.resolution,
        "origin": (info.origin[0], info.origin[1]),
        "negate": info.negate,
        "occupied_thresh": info.occupied_thresh,
        "free_thresh": info.free_thresh,
    }


_PGM_TOKEN = re.compile(rb"\s*(?:#[^\n]*\n\s*)*(\S+)")


def read_pgm(path: str | Path) -> NDArray[np.float64]:
    """Read a binary (P5) or plain (P2) PGM image, top row first, as brightness 0 (black) .. 1 (white)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as error:
        raise MapError(f"{path}: cannot read the map image ({error.strerror}); fix: check 'image:'") from None
    if data[:2] not in (b"P5", b"P2"):
        raise MapError(
            f"{path}: not a PGM image (starts with {data[:8]!r}); fix: export it as PGM (P5 or P2)"
        )
    header: list[bytes] = []
    position = 0
    while len(header) < 4:
        match = _PGM_TOKEN.match(data, position)
        if match is None:
            raise MapError(f"{path}: truncated PGM header; fix: re-export the image as PGM")
        header.append(match.group(1))
        position = match.end()
    magic, width_text, height_text, maxval_text = header
    try:
        width, height, maxval = int(width_text), int(height_text), int(maxval_text)
    except ValueError:
        width = height = maxval = 0
    if min(width, height, maxval) <= 0 or maxval > 65535:
        raise MapError(f"{path}: bad PGM header {b' '.join(header)[:80]!r}; fix: re-export the image as PGM")
    _check_cells(path, width, height)
    return _pgm_pixels(
        path, data[position + 1 :] if magic == b"P5" else data[position:], magic, (height, width), maxval
    )


def _pgm_pixels(
    path: Path, body: bytes, magic: bytes, shape: tuple[int, int], maxval: int
) -> NDArray[np.float64]:
    count = shape[0] * shape[1]
    if magic == b"P2":
        values = np.array(body.split(), dtype=np.float64)
    else:
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype(np.uint8)
        values = np.frombuffer(body, dtype=dtype, count=min(count, len(body) // dtype.itemsize)).astype(
            np.float64
        )
    if values.size < count:
        raise MapError(
            f"{path}: PGM image has {values.size} pixels, its header promises {shape[1]}x{shape[0]}; "
            "fix: the file is truncated, re-export it"
        )
    return values[:count].reshape(shape) / maxval


# --- ARNL / MobileRobots .map ----------------------------------------------------------------------

_POSE_KINDS = {"GoalWithHeading": "goal", "Goal": "goal", "Dock": "dock", "RobotHome": "robot home"}
_KEEP_OUT_KINDS = {"ForbiddenArea", "ForbiddenLine"}
_SECTION_KEYWORD = re.compile(r"^[A-Za-z_]+$")
_SECTION_WIDTHS = {"LINES": 4, "DATA": 2}
_ARNL_FIX = "fix: repair or delete that line (Mapper3 can re-save the map)"


@dataclass
class _ArnlContent:
    """What an ARNL map file says, still in the file's order, converted to metres."""

    points: NDArray[np.float64]
    walls: NDArray[np.float64]
    poses: list[NamedPose]
    zones: list[KeepOutZone]


def load_arnl_map(path: str | Path, resolution: float = 0.05) -> OccupancyMap:
    """Load an ARNL ``.map`` file and rasterise its scan points and wall lines at ``resolution`` m/cell.

    Goal, Dock and RobotHome cairns become :class:`NamedPose` s; ForbiddenArea
    and ForbiddenLine cairns become :class:`KeepOutZone` s (kept even when they
    lie outside the scanned area). The grid's bounds come from the data, with a
    free margin of :data:`ARNL_MAP_MARGIN_M` around it.
    """
    path = Path(path)
    if not resolution > 0:
        raise MapError(f"{path}: resolution must be > 0 m/cell, got {resolution}")
    try:
        text_lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as error:
        raise MapError(f"{path}: cannot read the map file ({error.strerror}); fix: check the path") from None
    content = _parse_arnl(path, text_lines)
    return _rasterise_arnl(path, content, resolution)


def _parse_arnl(path: Path, text_lines: list[str]) -> _ArnlContent:
    first = text_lines[0].strip() if text_lines else ""
    if not first.startswith("2D-Map"):
        raise MapError(
            f"{path}: line 1: not an ARNL map (expected '2D-Map', found {first[:40]!r}); "
            "fix: give a MobileRobots/Mapper3 .map file, or a map_server .yaml for ROS maps"
        )
    sections: dict[str, list[tuple[int, str]]] = {name: [] for name in _SECTION_WIDTHS}
    poses: list[NamedPose] = []
    zones: list[KeepOutZone] = []
    section: str | None = None
    for number, line in enumerate(text_lines[1:], start=2):
        stripped = line.strip()
        if not stripped:
            continue
        if _SECTION_KEYWORD.match(stripped):
            section = stripped if stripped in sections else None
        elif section is not None:
            sections[section].append((number, stripped))
        elif stripped.startswith("Cairn:"):
            _add_cairn(path, number, stripped, poses, zones)
    return _ArnlContent(
        points=_parse_numbers(path, sections["DATA"], "DATA") / MM_PER_M,
        walls=_parse_numbers(path, sections["LINES"], "LINES") / MM_PER_M,
        poses=_unique_names(poses),
        zones=zones,
    )


def _parse_numbers(path: Path, rows: list[tuple[int, str]], section: str) -> NDArray[np.float64]:
    """The rows of a LINES or DATA section as an (n, width) array; MapError naming the first bad line."""
    width = _SECTION_WIDTHS[section]
    split_rows = [text.split() for _, text in rows]
    for (number, text), values in zip(rows, split_rows, strict=True):
        if len(values) != width:
            raise MapError(
                f"{path}: line {number}: {section} needs {width} numbers per line, "
                f"got {text[:40]!r}; {_ARNL_FIX}"
            )
    try:
        return np.array(split_rows, dtype=np.float64).reshape(-1, width)
    except ValueError:
        for (number, text), values in zip(rows, split_rows, strict=True):
            if not all(_is_number(value) for value in values):
                raise MapError(f"{path}: line {number}: not a number in {text[:40]!r}; {_ARNL_FIX}") from None
        raise


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _add_cairn(path: Path, number: int, line: str, poses: list[NamedPose], zones: list[KeepOutZone]) -> None:
    """Parse ``Cairn: TYPE X Y THETA "internal" ICON "label" [x1 y1 x2 y2]`` into a pose or keep-out zone."""
    where = f"{path.name} line {number}"
    try:
        tokens = shlex.split(line)
    except ValueError as error:
        raise MapError(f"{path}: line {number}: cannot split the Cairn line ({error}); {_ARNL_FIX}") from None
    kind = tokens[1] if len(tokens) > 1 else ""
    if kind not in _POSE_KINDS and kind not in _KEEP_OUT_KINDS:
        return
    if len(tokens) not in (8, 12):
        raise MapError(
            f'{path}: line {number}: a {kind} Cairn needs \'X Y THETA "description" ICON "label"\' '
            f"and maybe 'x1 y1 x2 y2'; got {len(tokens) - 1} fields; {_ARNL_FIX}"
        )
    try:
        x, y, theta_deg = (float(value) for value in tokens[2:5])
        rectangle = [float(value) / MM_PER_M for value in tokens[8:12]]
    except ValueError:
        raise MapError(
            f"{path}: line {number}: X, Y, THETA and x1 y1 x2 y2 must be numbers; {_ARNL_FIX}"
        ) from None
    frame = (x / MM_PER_M, y / MM_PER_M, math.radians(theta_deg))
    description, label = tokens[5], tokens[7]
    if kind in _KEEP_OUT_KINDS:
        if not rectangle:
            raise MapError(f"{path}: line {number}: a {kind} needs its 'x1 y1 x2 y2' corners; {_ARNL_FIX}")
        x1, y1, x2, y2 = rectangle
        local = [(x1, y1), (x2, y2)] if kind == "ForbiddenLine" else [(x1, y1), (x2, y1), (x2, y2), (x1, y2)]
        zones.append(KeepOutZone(tuple(_to_map_frame(frame, p) for p in local), name=label, source=where))
        return
    if rectangle:
        x1, y1, x2, y2 = rectangle
        centre_x, centre_y = _to_map_frame(frame, ((x1 + x2) / 2, (y1 + y2) / 2))
    else:
        centre_x, centre_y = frame[0], frame[1]
    heading = 0.0 if kind == "Goal" else frame[2]
    name = label or _POSE_KINDS[kind]
    poses.append(
        NamedPose(name, centre_x, centre_y, heading, kind=kind, description=description, source=where)
    )


def _to_map_frame(frame: tuple[float, float, float], point: Point) -> Point:
    """A point given in a cairn's own frame (x, y, heading), in map coordinates."""
    x, y, theta = frame
    cos_t, sin_t = math.cos(theta), math.sin(theta)
    return (x + point[0] * cos_t - point[1] * sin_t, y + point[0] * sin_t + point[1] * cos_t)


def _unique_names(poses: list[NamedPose]) -> list[NamedPose]:
    """Rename repeated names ``home``, ``home 2``, ``home 3`` ... so every pose can be asked for by name."""
    seen: dict[str, int] = {}
    unique = []
    for pose in poses:
        seen[pose.name] = seen.get(pose.name, 0) + 1
        if seen[pose.name] > 1:
            pose = NamedPose(
                f"{pose.name} {seen[pose.name]}",
                pose.x,
                pose.y,
                pose.theta,
                pose.kind,
                pose.description,
                pose.source,
            )
        unique.append(pose)
    return unique


def _check_cells(path: Path, width: float, height: float, resolution: float | None = None) -> None:
    """Refuse a map of more than MAX_MAP_CELLS cells before allocating it."""
    if width * height <= MAX_MAP_CELLS:
        return
    size = (
        f" ({width * resolution:,.0f} m x {height * resolution:,.0f} m at {resolution} m/cell)"
        if resolution
        else ""
    )
    raise MapError(
        f"{path}: the map would be {width:,.0f} x {height:,.0f} cells{size}, over the limit of "
        f"{MAX_MAP_CELLS:,} cells; fix: check for stray far-away points or lines, crop the map, or use a "
        "coarser resolution"
    )


def _rasterise_arnl(path: Path, content: _ArnlContent, resolution: float) -> OccupancyMap:
    corners = [content.points, content.walls.reshape(-1, 2), np.array([p.position for p in content.poses])]
    known = np.concatenate([c.reshape(-1, 2) for c in corners])
    if not len(content.points) and not len(content.walls):
        raise MapError(f"{path}: the map has no scan points (DATA) and no wall lines (LINES); fix: add some")
    if not np.isfinite(known).all():
        raise MapError(
            f"{path}: a point, line or cairn has a coordinate that is not a finite number; {_ARNL_FIX}"
        )
    low = known.min(axis=0) - ARNL_MAP_MARGIN_M
    high = known.max(axis=0) + ARNL_MAP_MARGIN_M
    extent = np.ceil((high - low) / resolution)
    _check_cells(path, float(extent[0]), float(extent[1]), resolution)
    cols, rows = extent.astype(int)
    grid = np.zeros((rows, cols), dtype=np.uint8)
    if len(content.points):
        cells = np.floor((content.points - low) / resolution).astype(int)
        grid[cells[:, 1], cells[:, 0]] = Cell.OCCUPIED
    walls = np.zeros(grid.shape, dtype=bool)
    for x1, y1, x2, y2 in (content.walls - np.tile(low, 2)) / resolution:
        mark_segment(walls, (x1, y1), (x2, y2))
    grid[walls] = Cell.OCCUPIED
    return OccupancyMap(
        grid=grid,
        resolution=resolution,
        origin=(float(low[0]), float(low[1])),
        poses=tuple(content.poses),
        keep_out=tuple(content.zones),
        source=str(path),
    )
