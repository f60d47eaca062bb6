"""The navigation module's database: known places, scheduled visits and things to say (SQLite).

Part of the navigation module's pure logic/persistence layer. One SQLite file
holds three kinds of data:

* locations: a name, aliases (what speech-to-text hears instead), the map they are
  on, a pose (x, y in m, heading in rad; no x and y while the pose is not known),
  how close counts as arrived, whether the place is usually crowded and how
  pleasant the robot finds it (-1..1);
* calendar events: be at a location between two times, optionally recurring
  (RFC 5545 RRULE), optionally ignored, with a UID so an .ics import updates;
* responses: sentences with the placeholder ``LOCATION``, by response type and
  emotion (NULL emotion = fits any emotion).
* the map in use: the map imported last (``import_pose`` records it). Only
  places with a pose on it are targets (any place with a pose before a map was
  imported); the default places have no pose until a map's goal places them.

A missing file is created with defaults. A file that is not a database, fails
``PRAGMA integrity_check`` or holds someone else's tables is moved aside to
``<name>.corrupt-<timestamp>`` with a warning and recreated, so the robot always
starts. Writes are committed at once (WAL, synchronous=FULL). The schema version
lives in ``PRAGMA user_version`` and older files are migrated on open.
"""

from __future__ import annotations

import enum
import logging
import math
import re
import sqlite3
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from datetime import UTC, datetime, timedelta, timezone, tzinfo
from typing import Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from cyborg.emotion.model import TABLE_2_2_ALIASES
from cyborg.errors import CyborgError, DatabaseError
from cyborg.navigation.calendar import normalise_recurrence, occurrences_between
from cyborg.navigation.keywords import LocationMatcher, normalise
from cyborg.storage import SQLiteFile, Unusable, transaction

log = logging.getLogger(__name__)

PLACEHOLDER = "LOCATION"
"""Word in a response sentence that is replaced by the location's name."""

_PLACEHOLDER = "map = '' AND x = 0 AND y = 0 AND heading = 0"
"""SQL: a row holding the (0, 0) placeholder pose that files before version 3 gave places on no map."""

# Each migration takes the file from version i to i + 1 (index i).
_MIGRATIONS: tuple[tuple[str, ...], ...] = (
    (
        "CREATE TABLE locations (id INTEGER PRIMARY KEY, name TEXT NOT NULL UNIQUE COLLATE NOCASE, "
        "map TEXT NOT NULL DEFAULT '', x REAL NOT NULL DEFAULT 0, y REAL NOT NULL DEFAULT 0, "
        "heading REAL NOT NULL DEFAULT 0, tolerance REAL NOT NULL DEFAULT 0.5 CHECK (tolerance > 0), "
        "crowded INTEGER NOT NULL DEFAULT 0 CHECK (crowded IN (0, 1)), "
        "pleasantness REAL NOT NULL DEFAULT 0 CHECK (pleasantness BETWEEN -1 AND 1))",
        "CREATE TABLE location_aliases (alias TEXT PRIMARY KEY COLLATE NOCASE, "
        "location_id INTEGER NOT NULL REFERENCES locations(id) ON DELETE CASCADE)",
        "CREATE TABLE events (id INTEGER PRIMARY KEY, "
        "location_id INTEGER NOT NULL REFERENCES locations(id) ON DELETE RESTRICT, "
        "start_utc TEXT NOT NULL, end_utc TEXT NOT NULL, timezone TEXT NOT NULL, "
        "ignored INTEGER NOT NULL DEFAULT 0 CHECK (ignored IN (0, 1)), "
        "recurrence TEXT, summary TEXT, uid TEXT UNIQUE)",
        "CREATE TABLE responses (id INTEGER PRIMARY KEY, sentence TEXT NOT NULL, "
        "type TEXT NOT NULL, emotion TEXT)",
        "CREATE INDEX responses_by_type ON responses (type, emotion)",
    ),
    (
        # Which map the robot uses now (the one imported last): only places on it are targets.
        "CREATE TABLE settings (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    ),
    (
        # A place may have no pose (x and y NULL): it is no target until a map or `set-pose` gives
        # it one. SQLite cannot drop NOT NULL in place, so the rows move to a new table; the (0, 0)
        # placeholders of places on no map lose their made-up pose, everything else is kept.
        "CREATE TABLE locations_v3 (id INTEGER PRIMARY KEY, name TEXT NOT NULL UNIQUE COLLATE NOCASE, "
        "map TEXT NOT NULL DEFAULT '', x REAL, y REAL, "
        "heading REAL NOT NULL DEFAULT 0, tolerance REAL NOT NULL DEFAULT 0.5 CHECK (tolerance > 0), "
        "crowded INTEGER NOT NULL DEFAULT 0 CHECK (crowded IN (0, 1)), "
        "pleasantness REAL NOT NULL DEFAULT 0 CHECK (pleasantness BETWEEN -1 AND 1), "
        "CHECK ((x IS NULL) = (y IS NULL)))",
        f"INSERT INTO locations_v3 (id, name, map, x, y, heading, tolerance, crowded, pleasantness) "
        f"SELECT id, name, map, CASE WHEN {_PLACEHOLDER} THEN NULL ELSE x END, "
        f"CASE WHEN {_PLACEHOLDER} THEN NULL ELSE y END, heading, tolerance, crowded, pleasantness "
        "FROM locations",
        "DROP TABLE locations",
        "ALTER TABLE locations_v3 RENAME TO locations",
    ),
)
SCHEMA_VERSION = len(_MIGRATIONS)
_COLUMNS: dict[str, set[str]] = {
    "locations": {"id", "name", "map", "x", "y", "heading", "tolerance", "crowded", "pleasantness"},
    "location_aliases": {"alias", "location_id"},
    "events": {
        "id",
        "location_id",
        "start_utc",
        "end_utc",
        "timezone",
        "ignored",
        "recurrence",
        "summary",
        "uid",
    },
    "responses": {"id", "sentence", "type", "emotion"},
    "settings": {"key", "value"},
}
CURRENT_MAP_KEY = "current_map"


class ResponseType(enum.Enum):
    """What a sentence is for; some kinds must name the place (contain ``LOCATION``)."""

    OPINION = "opinion"
    ARRIVED = "arrived"
    STUCK = "stuck"
    OFFER_GUIDE = "offer_guide"
    CONFIRM = "confirm"
    REFUSE = "refuse"
    ASK_LOCATION = "ask_location"
    UNKNOWN_LOCATION = "unknown_location"
    DECLINED = "declined"
    NOT_ON_MAP = "not_on_map"
    NO_POSE = "no_pose"
    RESUME = "resume"

    @property
    def needs_location(self) -> bool:
        return self in (
            ResponseType.OPINION,
            ResponseType.ARRIVED,
            ResponseType.STUCK,
            ResponseType.NOT_ON_MAP,
            ResponseType.NO_POSE,
        )


NEW_RESPONSE_TYPES: dict[int, tuple[ResponseType, ...]] = {
    2: (ResponseType.NOT_ON_MAP,),
    3: (ResponseType.NO_POSE, ResponseType.RESUME),
}
"""Response types added by a schema version: migrating an older file adds their default sentences."""


@dataclass(frozen=True)
class Location:
    """A known place; ``x`` and ``y`` are None while its pose is not known (then it is no target)."""

    name: str
    aliases: tuple[str, ...] = ()
    map: str = ""
    x: float | None = None
    y: float | None = None
    heading: float = 0.0
    tolerance: float = 0.5
    crowded: bool = False
    pleasantness: float = 0.0

    @property
    def position(self) -> tuple[float, float] | None:
        """(x, y) in metres, or None if the place has no pose."""
        return None if self.x is None or self.y is None else (self.x, self.y)


@dataclass(frozen=True)
class CalendarEvent:
    """Be at ``location`` from ``start`` to ``end`` (aware datetimes), maybe recurring."""

    location: str
    start: datetime
    end: datetime
    ignored: bool = False
    recurrence: str | None = None
    summary: str | None = None
    uid: str | None = None
    id: int | None = None


@dataclass(frozen=True)
class Occurrence:
    """One occurrence of a (possibly recurring) calendar event."""

    event: CalendarEvent
    start: datetime
    end: datetime


@dataclass(frozen=True)
class Response:
    """A sentence the robot can say; ``emotion`` None fits every emotion."""

    sentence: str
    type: ResponseType
    emotion: str | None = None
    id: int | None = None

    def say(self, location: str) -> str:
        """The sentence with ``LOCATION`` replaced by ``location``."""
        return self.sentence.replace(PLACEHOLDER, location)


DEFAULT_LOCATIONS: tuple[Location, ...] = (
    Location("information desk", ("info", "information"), crowded=True, pleasantness=0.3),
    Location("cafeteria", ("canteen",), crowded=True, pleasantness=0.8),
    Location("entrance", ("main entrance",), crowded=True, pleasantness=0.1),
    Location("entrance 2", ("entrance2",), pleasantness=0.0),
    Location("el5", (), pleasantness=0.2),
    Location("el6", ("e16",), pleasantness=0.2),
    Location("waiting area", (), crowded=True, pleasantness=0.4),
    Location("elevator", ("lift",), pleasantness=-0.3),
)
"""Glassgården, NTNU; no poses: a map's goals (``cyborg db import-map``) or ``set-pose`` give them."""

_R = ResponseType
DEFAULT_RESPONSES: tuple[Response, ...] = (
    Response("I like the LOCATION.", _R.OPINION),
    Response("I am happy about LOCATION", _R.OPINION, "neutral"),
    Response("I love the LOCATION, it is one of my favourite places!", _R.OPINION, "elated"),
    Response("The LOCATION makes me smile.", _R.OPINION, "elated"),
    Response("What is this place? A LOCATION you say?", _R.OPINION, "curious"),
    Response("I wonder what goes on at the LOCATION.", _R.OPINION, "curious"),
    Response("I hate the LOCATION.", _R.OPINION, "angry"),
    Response("Do not talk to me about the LOCATION.", _R.OPINION, "angry"),
    Response("The LOCATION is so boring.", _R.OPINION, "bored"),
    Response("Nothing ever happens at the LOCATION.", _R.OPINION, "bored"),
    Response("The LOCATION makes me feel a bit down.", _R.OPINION, "inhibited"),
    Response("The LOCATION is fine, I suppose.", _R.OPINION, "unconcerned"),
    Response("Oh! The LOCATION? I did not expect that.", _R.OPINION, "puzzled"),
    Response("The LOCATION is a place of some importance, like me.", _R.OPINION, "dignified"),
    Response("Everyone at the LOCATION is so kind to me.", _R.OPINION, "loved"),
    Response("Human, this is LOCATION", _R.ARRIVED),
    Response("There. The LOCATION. Happy now?", _R.ARRIVED, "angry"),
    Response("I am stuck and cannot get to the LOCATION.", _R.STUCK),
    Response("Something is blocking my way to the LOCATION!", _R.STUCK, "angry"),
    Response("I tried, but I could not reach the LOCATION.", _R.STUCK, "inhibited"),
    Response("I think I know where that is, would you like me to show you?", _R.OFFER_GUIDE),
    Response("At once.", _R.CONFIRM),
    Response("Fine, if I must.", _R.CONFIRM, "bored"),
    Response("No. Go there yourself.", _R.REFUSE),
    Response("I will not go to the LOCATION, leave me alone.", _R.REFUSE, "angry"),
    Response("Where would you like me to go?", _R.ASK_LOCATION),
    Response("I am sorry, I do not know that place.", _R.UNKNOWN_LOCATION),
    Response("All right, maybe another time.", _R.DECLINED),
    Response("I know the LOCATION, but it is not on the map I have here.", _R.NOT_ON_MAP),
    Response("I have heard of the LOCATION, but I do not know where it is.", _R.NO_POSE),
    Response("Now, on to LOCATION.", _R.RESUME),
)


class NavigationDatabase(SQLiteFile):
    """The SQLite file of the navigation module; every method commits before returning."""

    what = "navigation database"
    foreign_keys = True

    def _prepare(self, conn: sqlite3.Connection) -> None:
        """Check the file, migrate it to SCHEMA_VERSION and seed a new one."""
        try:
            check = conn.execute("PRAGMA integrity_check").fetchall()
            version = int(conn.execute("PRAGMA user_version").fetchone()[0])
            tables = {row[0] for row in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        except sqlite3.DatabaseError as exc:
            raise Unusable(str(exc)) from exc
        if check != [("ok",)]:
            raise Unusable(f"integrity_check failed: {check[:3]}")
        if version > SCHEMA_VERSION:
            raise DatabaseError(
                f"{self.path} has schema version {version}, newer than this program's {SCHEMA_VERSION}; "
                "update cyborg, or point --db at another file"
            )
        if version == 0 and tables:
            raise Unusable(f"it holds other tables ({', '.join(sorted(tables))}) and no schema version")
        if version < SCHEMA_VERSION:
            self._migrate(conn, version)
        self._check_columns(conn)

    def _migrate(self, conn: sqlite3.Connection, version: int) -> None:
        """Take the file from ``version`` to SCHEMA_VERSION in one transaction (a new file: seed it).

        Foreign keys are off meanwhile (a step may rebuild a table others refer to) and checked
        before the commit, as SQLite's procedure for changing a table asks.
        """
        unplaced: list[str] = []
        conn.execute("PRAGMA foreign_keys = OFF")
        try:
            with transaction(conn):
                for step in range(version, SCHEMA_VERSION):
                    if step == 2:  # to version 3: placeholder poses become "no pose"
                        rows = conn.execute(f"SELECT name FROM locations WHERE {_PLACEHOLDER} ORDER BY name")
                        unplaced = [str(row[0]) for row in rows]
                    for sql in _MIGRATIONS[step]:
                        conn.execute(sql)
                    if version > 0:
                        self._seed_responses(conn, NEW_RESPONSE_TYPES.get(step + 1, ()))
                if version == 0:
                    self._seed(conn)
                broken = conn.execute("PRAGMA foreign_key_check").fetchall()
                if broken:
                    raise sqlite3.IntegrityError(f"rows refer to missing ones: {broken[:3]}")
                conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
        except sqlite3.Error as exc:
            raise DatabaseError(
                f"could not migrate {self.path} from schema version {version} to {SCHEMA_VERSION}: {exc}; "
                "check the disk, or move the file away to start afresh"
            ) from exc
        finally:
            if self.foreign_keys:
                conn.execute("PRAGMA foreign_keys = ON")
        if version > 0:
            log.info(
                "navigation database %s migrated from schema version %d to %d",
                self.path,
                version,
                SCHEMA_VERSION,
            )
        if unplaced:
            log.warning(
                "navigation database %s: %s had the (0, 0) placeholder pose and no map; they have no pose "
                "now and are no targets until they get one: `cyborg db import-map MAP` (a map whose goals "
                "name them) or `cyborg db locations set-pose NAME --x X --y Y`",
                self.path,
                ", ".join(unplaced),
            )

    @staticmethod
    def _check_columns(conn: sqlite3.Connection) -> None:
        for table, columns in _COLUMNS.items():
            found = {row[1] for row in conn.execute(f"PRAGMA table_info({table})")}
            if not columns <= found:
                raise Unusable(f"table {table} lacks columns {sorted(columns - found)}")

    def _seed(self, conn: sqlite3.Connection) -> None:
        for location in DEFAULT_LOCATIONS:
            self._insert_location(conn, location)
        self._seed_responses(conn, tuple(ResponseType))

    @staticmethod
    def _seed_responses(conn: sqlite3.Connection, kinds: Iterable[ResponseType]) -> None:
        """Add the default sentences of each of ``kinds`` that has no sentence yet."""
        for kind in kinds:
            [(count,)] = conn.execute("SELECT COUNT(*) FROM responses WHERE type = ?", (kind.value,))
            if count:
                continue
            conn.executemany(
                "INSERT INTO responses (sentence, type, emotion) VALUES (?, ?, ?)",
                [(r.sentence, r.type.value, r.emotion) for r in DEFAULT_RESPONSES if r.type is kind],
            )

    # --- the map in use ----------------------------------------------------------------------

    def current_map(self) -> str | None:
        """The map the robot uses (the one imported last), or None before any map was imported."""
        rows = self._read("SELECT value FROM settings WHERE key = ?", (CURRENT_MAP_KEY,))
        return str(rows[0][0]) if rows else None

    def use_map(self, map_name: str) -> None:
        """Record ``map_name`` as the map the robot uses: from now on only places on it are targets."""
        name = map_name.strip()
        if not name:
            raise DatabaseError("the map name is empty; give the map's name, e.g. its file's stem 'campus'")
        if name == self.current_map():
            return
        with self._writing(f"set the map in use to {name!r}") as conn:
            conn.execute(
                "INSERT INTO settings (key, value) VALUES (?, ?) "
                "ON CONFLICT (key) DO UPDATE SET value = excluded.value",
                (CURRENT_MAP_KEY, name),
            )
        log.info("navigation database %s: the robot now uses map %r", self.path, name)

    def on_current_map(self, location: Location) -> bool:
        """True if ``location`` is on the map in use (any place is, before a map was imported)."""
        current = self.current_map()
        return current is None or location.map == current

    def is_target(self, location: Location) -> bool:
        """True if the robot can go to ``location``: it has a pose, and that pose is on the map in use."""
        return location.position is not None and self.on_current_map(location)

    def locations_on_map(self) -> list[Location]:
        """The places the robot can go to: those with a pose on the map in use (see :meth:`is_target`)."""
        current = self.current_map()
        return [
            loc
            for loc in self.list_locations()
            if loc.position is not None and (current is None or loc.map == current)
        ]

    def no_pose_reason(self, location: Location) -> str:
        """Why ``location`` is no target because it has no pose, and how to give it one (for logs)."""
        return (
            f"location {location.name!r} has no pose, so the robot does not know where it is; fix: import "
            f"a map whose goals name it (`cyborg db import-map MAP`), or give it one with "
            f"`cyborg db locations set-pose {location.name!r} --x X --y Y`"
        )

    def off_map_reason(self, location: Location) -> str:
        """Why ``location`` is no target, and how to fix it (for logs)."""
        where = f"on map {location.map!r}" if location.map else "not placed on any map"
        return (
            f"location {location.name!r} is {where}, not on the map in use ({self.current_map()!r}); "
            "fix: import a map that has it (`cyborg db import-map MAP`), or give it a pose on this map: "
            f"`cyborg db locations set-pose {location.name!r} --x X --y Y`"
        )

    # --- locations ---------------------------------------------------------------------------

    def import_pose(self, pose: Any, map_name: str) -> str:
        """Add or update one location from a map pose; a line saying what happened.

        ``map_name`` becomes the map in use (:meth:`use_map`). A pose whose name is
        a known name or alias moves that place. Else, a pose named like a default
        place after normalisation (``waitingarea`` ~ "waiting area", ``elevator1``
        ~ "elevator": the first of several) places that default place and becomes
        its alias, unless another pose of this map placed it already.
        """
        self.use_map(map_name)
        x, y, heading = float(pose.x), float(pose.y), float(pose.theta)
        if not all(math.isfinite(v) for v in (x, y, heading)):
            return f"skipped {pose.name!r}: its pose ({x}, {y}, {heading}) is not finite"
        known = self.find_location(pose.name)
        try:
            if known is None:
                default = self._default_place_named_like(pose.name, map_name.strip())
                if default is not None:
                    spoken = {normalise(form) for form in (default.name, *default.aliases)}
                    aliases = default.aliases
                    if normalise(pose.name) not in spoken:
                        aliases = (*aliases, " ".join(str(pose.name).split()))
                    moved = replace(default, aliases=aliases, map=map_name, x=x, y=y, heading=heading)
                    self.update_location(default.name, moved)
                    return f"updated {default.name!r} (the map's {pose.name!r}) to ({x:.2f}, {y:.2f})"
                self.add_location(Location(pose.name, map=map_name, x=x, y=y, heading=heading))
                return f"added {pose.name!r} at ({x:.2f}, {y:.2f})"
            self.update_location(known.name, replace(known, map=map_name, x=x, y=y, heading=heading))
            return f"updated {known.name!r} to ({x:.2f}, {y:.2f})"
        except CyborgError as exc:
            return f"skipped {pose.name!r}: {exc}"

    def _default_place_named_like(self, name: str, map_name: str) -> Location | None:
        """The stored default place a map goal called ``name`` stands for, if not on ``map_name`` yet."""
        key = _compact(name)
        keys = [key]
        first = re.fullmatch(r"(.*\D)1", key)  # "elevator1": the first elevator is "the elevator"
        if first:
            keys.append(first.group(1))
        for wanted in keys:
            for default in DEFAULT_LOCATIONS:
                if all(_compact(form) != wanted for form in (default.name, *default.aliases)):
                    continue
                place = self.find_location(default.name)
                if place is not None and place.map != map_name:
                    return place
        return None

    def set_pose(
        self, name_or_alias: str, x: float, y: float, heading: float = 0.0, map_name: str | None = None
    ) -> Location:
        """Give the place called ``name_or_alias`` a pose on ``map_name`` (default: the map in use).

        Its name, aliases, calendar events and the rest are kept.
        """
        place = self.get_location(name_or_alias)
        on_map = (self.current_map() or "") if map_name is None else map_name
        return self.update_location(place.name, replace(place, map=on_map, x=x, y=y, heading=heading))

    def list_locations(self) -> list[Location]:
        rows = self._read("SELECT * FROM locations ORDER BY name COLLATE NOCASE")
        return [self._location_from_row(row) for row in rows]

    def find_location(self, name_or_alias: str) -> Location | None:
        """The location called ``name_or_alias`` (name or alias, any case), or None."""
        location_id = self._location_id(name_or_alias)
        if location_id is None:
            return None
        [row] = self._read("SELECT * FROM locations WHERE id = ?", (location_id,))
        return self._location_from_row(row)

    def get_location(self, name_or_alias: str) -> Location:
        """Like :meth:`find_location` but raises DatabaseError naming the known places."""
        found = self.find_location(name_or_alias)
        if found is None:
            raise self._unknown_location(name_or_alias)
        return found

    def matcher(self, threshold: float | None = None, *, on_map: bool = False) -> LocationMatcher:
        """A keyword matcher over the locations (only those on the map in use if ``on_map``)."""
        locations = self.locations_on_map() if on_map else self.list_locations()
        places = [(loc.name, loc.aliases) for loc in locations]
        return LocationMatcher(places) if threshold is None else LocationMatcher(places, threshold)

    def add_location(self, location: Location) -> Location:
        """Add a new place; DatabaseError if its name or an alias is taken or a value is out of range."""
        location = self._checked_location(location, own_id=None)
        with self._writing(f"add location {location.name!r}") as conn:
            self._insert_location(conn, location)
        return location

    def update_location(self, name_or_alias: str, location: Location) -> Location:
        """Replace the place called ``name_or_alias`` by ``location`` (which may rename it)."""
        location_id = self._location_id(name_or_alias)
        if location_id is None:
            raise self._unknown_location(name_or_alias)
        location = self._checked_location(location, own_id=location_id)
        with self._writing(f"update location {location.name!r}") as conn:
            conn.execute(
                "UPDATE locations SET name = ?, map = ?, x = ?, y = ?, heading = ?, tolerance = ?, "
                "crowded = ?, pleasantness = ? WHERE id = ?",
                (*self._location_values(location), location_id),
            )
            conn.execute("DELETE FROM location_aliases WHERE location_id = ?", (location_id,))
            self._insert_aliases(conn, location_id, location.aliases)
        return location

    def remove_location(self, name_or_alias: str, *, with_events: bool = False) -> Location:
        """Remove a place; its calendar events too if ``with_events``, else refuse while it has any."""
        location = self.get_location(name_or_alias)
        location_id = self._location_id(location.name)
        event_ids = [
            int(str(r[0])) for r in self._read("SELECT id FROM events WHERE location_id = ?", (location_id,))
        ]
        if event_ids and not with_events:
            raise DatabaseError(
                f"location {location.name!r} has calendar events {event_ids}; remove them first "
                "or remove the location with its events (--with-events)"
            )
        with self._writing(f"remove location {location.name!r}") as conn:
            conn.execute("DELETE FROM events WHERE location_id = ?", (location_id,))
            conn.execute("DELETE FROM locations WHERE id = ?", (location_id,))
        return location

    def _location_id(self, name_or_alias: str) -> int | None:
        key = " ".join(name_or_alias.split())
        rows = self._read(
            "SELECT id FROM locations WHERE name = ? UNION "
            "SELECT location_id FROM location_aliases WHERE alias = ?",
            (key, key),
        )
        return int(str(rows[0][0])) if rows else None

    def _unknown_location(self, name: str) -> DatabaseError:
        known = ", ".join(loc.name for loc in self.list_locations()) or "none"
        guess = self.matcher().find(name)
        hint = f"; did you mean {guess.location!r}?" if guess else ""
        return DatabaseError(f"unknown location {name!r}{hint} Known locations: {known}; add it first")

    def _checked_location(self, location: Location, own_id: int | None) -> Location:
        location = _valid_location(location)
        taken = self._spoken_forms(exclude_id=own_id)
        for form in (location.name, *location.aliases):
            owner = taken.get(normalise(form))
            if owner is not None:
                raise DatabaseError(
                    f"{form!r} is already used by location {owner!r}; choose another name or alias"
                )
        return location

    def _spoken_forms(self, exclude_id: int | None) -> dict[str, str]:
        """Normalised names and aliases of all other locations -> the name they belong to."""
        forms: dict[str, str] = {}
        for location_id, name in self._read("SELECT id, name FROM locations"):
            if location_id != exclude_id:
                forms[normalise(str(name))] = str(name)
        for alias, name, location_id in self._read(
            "SELECT a.alias, l.name, l.id FROM location_aliases a JOIN locations l ON l.id = a.location_id"
        ):
            if location_id != exclude_id:
                forms[normalise(str(alias))] = str(name)
        return forms

    @staticmethod
    def _location_values(location: Location) -> tuple[object, ...]:
        return (
            location.name,
            location.map,
            location.x,
            location.y,
            location.heading,
            location.tolerance,
            int(location.crowded),
            location.pleasantness,
        )

    def _insert_location(self, conn: sqlite3.Connection, location: Location) -> None:
        cursor = conn.execute(
            "INSERT INTO locations (name, map, x, y, heading, tolerance, crowded, pleasantness) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
            self._location_values(location),
        )
        assert cursor.lastrowid is not None
        self._insert_aliases(conn, cursor.lastrowid, location.aliases)

    @staticmethod
    def _insert_aliases(conn: sqlite3.Connection, location_id: int, aliases: Iterable[str]) -> None:
        conn.executemany(
            "INSERT INTO location_aliases (alias, location_id) VALUES (?, ?)",
            [(alias, location_id) for alias in aliases],
        )

    def _location_from_row(self, row: tuple[object, ...]) -> Location:
        location_id, name, map_name, x, y, heading, tolerance, crowded, pleasant = row[:9]
        aliases = self._read(
            "SELECT alias FROM location_aliases WHERE location_id = ? ORDER BY alias", (location_id,)
        )
        return Location(
            name=str(name),
            aliases=tuple(str(a[0]) for a in aliases),
            map=str(map_name),
            x=None if x is None or y is None else _number(x, f"x of {name}"),
            y=None if x is None or y is None else _number(y, f"y of {name}"),
            heading=_number(heading, f"heading of {name}"),
            tolerance=_number(tolerance, f"tolerance of {name}", 0.5),
            crowded=bool(crowded),
            pleasantness=_number(pleasant, f"pleasantness of {name}"),
        )

    # --- calendar events ---------------------------------------------------------------------

    def list_events(
        self, location: str | None = None, *, include_ignored: bool = True
    ) -> list[CalendarEvent]:
        """All events (of one location if given), by start time."""
        sql = (
            "SELECT e.id, l.name, e.start_utc, e.end_utc, e.timezone, e.ignored, e.recurrence, e.summary, e.uid "
            "FROM events e JOIN locations l ON l.id = e.location_id"
        )
        where: list[str] = []
        params: list[object] = []
        if location is not None:
            where.append("l.name = ?")
            params.append(self.get_location(location).name)
        if not include_ignored:
            where.append("e.ignored = 0")
        if where:
            sql += " WHERE " + " AND ".join(where)
        events = [
            self._event_from_row(row) for row in self._read(sql + " ORDER BY e.start_utc, e.id", params)
        ]
        return [event for event in events if event is not None]

    def get_event(self, event_id: int) -> CalendarEvent:
        found = [event for event in self.list_events() if event.id == event_id]
        if not found:
            raise DatabaseError(
                f"no calendar event with id {event_id}; list them with `cyborg db events list`"
            )
        return found[0]

    def validate_event(self, event: CalendarEvent) -> CalendarEvent:
        """``event`` checked and normalised (stored location name, stored recurrence form)."""
        for label, moment in (("start", event.start), ("end", event.end)):
            if moment.tzinfo is None or moment.utcoffset() is None:
                raise DatabaseError(
                    f"{label} {moment.isoformat()} has no time zone; give one, e.g. {moment.isoformat()}+01:00"
                )
        if event.end <= event.start:
            raise DatabaseError(
                f"end {event.end.isoformat()} is not after start {event.start.isoformat()}; swap or fix them"
            )
        recurrence = event.recurrence.strip() if event.recurrence else None
        return replace(
            event,
            location=self.get_location(event.location).name,
            recurrence=normalise_recurrence(recurrence, event.start, event.end) if recurrence else None,
            summary=(event.summary or "").strip() or None,
            uid=(event.uid or "").strip() or None,
        )

    def add_event(self, event: CalendarEvent) -> CalendarEvent:
        """Add a calendar event; returns it with its id. DatabaseError if its UID exists."""
        event = self.validate_event(event)
        if event.uid is not None and self._event_id_by_uid(event.uid) is not None:
            raise DatabaseError(f"an event with uid {event.uid!r} exists; update it or give another uid")
        with self._writing("add a calendar event") as conn:
            return self._insert_event(conn, event)

    def update_event(self, event_id: int, event: CalendarEvent) -> CalendarEvent:
        """Replace event ``event_id`` by ``event`` (its id field is ignored)."""
        self.get_event(event_id)
        event = replace(self.validate_event(event), id=event_id)
        other = self._event_id_by_uid(event.uid) if event.uid else None
        if other is not None and other != event_id:
            raise DatabaseError(f"uid {event.uid!r} belongs to event {other}; give another uid")
        with self._writing(f"update calendar event {event_id}") as conn:
            conn.execute(
                "UPDATE events SET location_id = (SELECT id FROM locations WHERE name = ?), start_utc = ?, "
                "end_utc = ?, timezone = ?, ignored = ?, recurrence = ?, summary = ?, uid = ? WHERE id = ?",
                (*self._event_values(event), event_id),
            )
        return event

    def upsert_events(self, events: Sequence[CalendarEvent]) -> list[tuple[CalendarEvent, bool]]:
        """Add events, or update those whose UID exists (keeping their ignored flag), in one transaction.

        Returns each stored event with True if it was added, False if updated.
        """
        checked = [self.validate_event(event) for event in events]
        results: list[tuple[CalendarEvent, bool]] = []
        with self._writing("import calendar events") as conn:
            for event in checked:
                existing = self._event_id_by_uid(event.uid) if event.uid else None
                if existing is None:
                    results.append((self._insert_event(conn, event), True))
                    continue
                [(ignored,)] = conn.execute("SELECT ignored FROM events WHERE id = ?", (existing,)).fetchall()
                event = replace(event, id=existing, ignored=bool(ignored))
                conn.execute(
                    "UPDATE events SET location_id = (SELECT id FROM locations WHERE name = ?), start_utc = ?, "
                    "end_utc = ?, timezone = ?, ignored = ?, recurrence = ?, summary = ?, uid = ? WHERE id = ?",
                    (*self._event_values(event), existing),
                )
                results.append((event, False))
        return results

    def remove_event(self, event_id: int) -> CalendarEvent:
        event = self.get_event(event_id)
        with self._writing(f"remove calendar event {event_id}") as conn:
            conn.execute("DELETE FROM events WHERE id = ?", (event_id,))
        return event

    def events_between(self, window_start: datetime, window_end: datetime) -> list[Occurrence]:
        """Occurrences of non-ignored events overlapping ``[window_start, window_end)``, by start."""
        for label, moment in (("window_start", window_start), ("window_end", window_end)):
            if moment.tzinfo is None:
                raise ValueError(f"{label}={moment.isoformat()} is naive; pass an aware datetime")
        found = [
            Occurrence(event, start, end)
            for event in self.list_events(include_ignored=False)
            for start, end in occurrences_between(
                event.start, event.end, event.recurrence, window_start, window_end
            )
        ]
        return sorted(found, key=lambda occ: (occ.start, occ.event.id or 0))

    def ongoing_events(self, now: datetime) -> list[Occurrence]:
        """Occurrences of non-ignored events with ``start <= now < end`` (recurring ones expanded)."""
        if now.tzinfo is None:
            raise ValueError(
                f"now={now.isoformat()} is naive; pass an aware time, e.g. datetime.now(timezone.utc)"
            )
        return [occ for occ in self.events_between(now, now + timedelta(microseconds=1)) if occ.start <= now]

    def _event_id_by_uid(self, uid: str) -> int | None:
        rows = self._read("SELECT id FROM events WHERE uid = ?", (uid,))
        return int(str(rows[0][0])) if rows else None

    def _insert_event(self, conn: sqlite3.Connection, event: CalendarEvent) -> CalendarEvent:
        cursor = conn.execute(
            "INSERT INTO events (location_id, start_utc, end_utc, timezone, ignored, recurrence, summary, uid) "
            "VALUES ((SELECT id FROM locations WHERE name = ?), ?, ?, ?, ?, ?, ?, ?)",
            self._event_values(event),
        )
        return replace(event, id=cursor.lastrowid)

    @staticmethod
    def _event_values(event: CalendarEvent) -> tuple[object, ...]:
        return (
            event.location,
            event.start.astimezone(UTC).isoformat(),
            event.end.astimezone(UTC).isoformat(),
            _zone_key(event.start),
            int(event.ignored),
            event.recurrence,
            event.summary,
            event.uid,
        )

    def _event_from_row(self, row: tuple[object, ...]) -> CalendarEvent | None:
        event_id, location, start, end, zone_key, ignored, recurrence, summary, uid = row
        try:
            zone = _zone_from_key(str(zone_key))
            return CalendarEvent(
                location=str(location),
                start=datetime.fromisoformat(str(start)).astimezone(zone),
                end=datetime.fromisoformat(str(end)).astimezone(zone),
                ignored=bool(ignored),
                recurrence=None if recurrence is None else str(recurrence),
                summary=None if summary is None else str(summary),
                uid=None if uid is None else str(uid),
                id=int(str(event_id)),
            )
        except (ValueError, ZoneInfoNotFoundError) as exc:
            log.warning("skipping calendar event %s in %s: %s", event_id, self.path, exc)
            return None

    # --- responses ---------------------------------------------------------------------------

    def list_responses(
        self, response_type: ResponseType | None = None, emotion: str | None = None
    ) -> list[Response]:
        """Stored responses, filtered by type and exact emotion if given (no fallback)."""
        rows = self._read("SELECT id, sentence, type, emotion FROM responses ORDER BY type, emotion, id")
        wanted = _emotion_key(emotion) if emotion is not None else None
        found = []
        for row in rows:
            response = self._response_from_row(row)
            if response is None or (response_type is not None and response.type is not response_type):
                continue
            if wanted is None or response.emotion == wanted:
                found.append(response)
        return found

    def responses(self, response_type: ResponseType, emotion: str | None) -> list[Response]:
        """Sentences of ``response_type`` for ``emotion``; those for any emotion if there are none."""
        key = _emotion_key(emotion)
        of_type = self.list_responses(response_type)
        specific = [r for r in of_type if key is not None and r.emotion == key]
        return specific or [r for r in of_type if r.emotion is None]

    def add_response(self, response: Response) -> Response:
        response = self._checked_response(response, own_id=None)
        with self._writing("add a response") as conn:
            cursor = conn.execute(
                "INSERT INTO responses (sentence, type, emotion) VALUES (?, ?, ?)",
                (response.sentence, response.type.value, response.emotion),
            )
        return replace(response, id=cursor.lastrowid)

    def update_response(self, response_id: int, response: Response) -> Response:
        self._get_response(response_id)
        response = replace(self._checked_response(response, own_id=response_id), id=response_id)
        with self._writing(f"update response {response_id}") as conn:
            conn.execute(
                "UPDATE responses SET sentence = ?, type = ?, emotion = ? WHERE id = ?",
                (response.sentence, response.type.value, response.emotion, response_id),
            )
        return response

    def remove_response(self, response_id: int) -> Response:
        response = self._get_response(response_id)
        with self._writing(f"remove response {response_id}") as conn:
            conn.execute("DELETE FROM responses WHERE id = ?", (response_id,))
        return response

    def _get_response(self, response_id: int) -> Response:
        found = [r for r in self.list_responses() if r.id == response_id]
        if not found:
            raise DatabaseError(
                f"no response with id {response_id}; list them with `cyborg db responses list`"
            )
        return found[0]

    def _checked_response(self, response: Response, own_id: int | None) -> Response:
        sentence = " ".join(response.sentence.split())
        if not sentence:
            raise DatabaseError("the response sentence is empty; write what the robot should say")
        if response.type.needs_location and PLACEHOLDER not in sentence:
            raise DatabaseError(
                f"{response.type.value} sentence {sentence!r} lacks the placeholder {PLACEHOLDER}; "
                f"write e.g. 'I like the {PLACEHOLDER}'"
            )
        checked = replace(response, sentence=sentence, emotion=_emotion_key(response.emotion))
        for other in self.list_responses(checked.type):
            if other.id != own_id and (other.sentence, other.emotion) == (checked.sentence, checked.emotion):
                raise DatabaseError(f"response {sentence!r} exists already (id {other.id}); nothing to add")
        return checked

    def _response_from_row(self, row: tuple[object, ...]) -> Response | None:
        response_id, sentence, kind, emotion = row
        try:
            response_type = ResponseType(str(kind))
        except ValueError:
            log.warning("skipping response %s in %s: unknown type %r", response_id, self.path, kind)
            return None
        try:
            key = None if emotion is None else _emotion_key(str(emotion))
        except DatabaseError:
            log.warning(
                "response %s in %s has emotion %r, no name; it fits any emotion",
                response_id,
                self.path,
                emotion,
            )
            key = None
        return Response(str(sentence), response_type, key, int(str(response_id)))


# --- validation helpers ----------------------------------------------------------------------


def _valid_location(location: Location) -> Location:
    """``location`` with tidy names and a heading in [-pi, pi]; DatabaseError on bad values."""
    name = " ".join(location.name.split())
    if not normalise(name):
        raise DatabaseError(
            f"location name {location.name!r} has no letters or digits; give a name like 'cafeteria'"
        )
    aliases = tuple(dict.fromkeys(" ".join(a.split()) for a in location.aliases))
    spoken = [normalise(name)]
    for alias in aliases:
        if not normalise(alias):
            raise DatabaseError(
                f"alias {alias!r} of {name!r} has no letters or digits; remove it or spell it out"
            )
        if normalise(alias) in spoken:
            raise DatabaseError(f"alias {alias!r} of {name!r} repeats its name or another alias; remove it")
        spoken.append(normalise(alias))
    for label, value in (("x", location.x), ("y", location.y), ("heading", location.heading)):
        if value is not None and not math.isfinite(value):
            raise DatabaseError(f"{label}={value} of {name!r} is not a finite number; give metres/radians")
    if (location.x is None) != (location.y is None):
        given, missing = ("x", "y") if location.y is None else ("y", "x")
        raise DatabaseError(
            f"{name!r} has {given} but no {missing}; give both (its pose), or neither while the pose is not known"
        )
    if location.x is None and location.map.strip():
        raise DatabaseError(
            f"{name!r} is on map {location.map.strip()!r} but has no x and y; give its pose on that map, "
            "or leave the map out"
        )
    if not (math.isfinite(location.tolerance) and location.tolerance > 0):
        raise DatabaseError(f"tolerance={location.tolerance} of {name!r} must be > 0 m; e.g. 0.5")
    if not -1.0 <= location.pleasantness <= 1.0:
        raise DatabaseError(f"pleasantness={location.pleasantness} of {name!r} is outside -1..1; e.g. 0.5")
    heading = math.remainder(location.heading, 2 * math.pi)
    return replace(location, name=name, aliases=aliases, map=location.map.strip(), heading=heading)


def _compact(name: str) -> str:
    """A name as speech would match it, without spaces: "Waiting Area" and "waitingarea" -> "waitingarea"."""
    return "".join(normalise(name).split())


def _emotion_key(emotion: str | None) -> str | None:
    """Canonical emotion name (lower case, Table 2.2's bracketed words mapped to its names, so a
    sentence stored for 'happy' by an older version fits 'elated'); None/'' means any emotion."""
    if emotion is None or not emotion.strip():
        return None
    key = "_".join(emotion.strip().lower().split())
    if not re.fullmatch(r"[a-z][a-z0-9_]*", key):
        raise DatabaseError(f"emotion {emotion!r} is not a name; use e.g. elated, angry or curious")
    return TABLE_2_2_ALIASES.get(key, key)


def _zone_key(moment: datetime) -> str:
    """How the zone of ``moment`` is stored: an IANA key, 'UTC' or a fixed offset '+01:00'."""
    if isinstance(moment.tzinfo, ZoneInfo):
        return moment.tzinfo.key
    offset = moment.utcoffset() or timedelta(0)
    if not offset:
        return "UTC"
    sign = "-" if offset < timedelta(0) else "+"
    minutes = abs(int(offset.total_seconds())) // 60
    return f"{sign}{minutes // 60:02d}:{minutes % 60:02d}"


def _zone_from_key(key: str) -> tzinfo:
    if key == "UTC":
        return UTC
    fixed = re.fullmatch(r"([+-])(\d\d):(\d\d)", key)
    if fixed:
        offset = timedelta(hours=int(fixed.group(2)), minutes=int(fixed.group(3)))
        return timezone(-offset if fixed.group(1) == "-" else offset)
    return ZoneInfo(key)


def _number(value: object, what: str, default: float = 0.0) -> float:
    """A stored number hand-edited into nonsense becomes ``default`` (logged) instead of a crash."""
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    log.warning("%s is %r, not a finite number; using %s", what, value, default)
    return default
