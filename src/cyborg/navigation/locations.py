"""The places of the navigation database (tables ``locations``, ``location_aliases``) and the map in use.

One of the record stores that :class:`~cyborg.navigation.database.NavigationDatabase`
combines; it works on the connection :class:`~cyborg.storage.SQLiteFile` opened. A place
has a name, aliases, a pose on a map (or none yet) and how the robot feels about it. The
map in use (table ``settings``) is the one imported last: only places with a pose on it
are targets (any place with a pose, before a map was imported).
"""

from __future__ import annotations

import logging
import math
import sqlite3
from collections.abc import Iterable
from dataclasses import replace

from cyborg.errors import DatabaseError
from cyborg.navigation.keywords import LocationMatcher, normalise
from cyborg.navigation.models import Location, valid_location
from cyborg.storage import SQLiteFile

log = logging.getLogger(__name__)

CURRENT_MAP_KEY = "current_map"
"""Key in table ``settings`` of the map in use."""


class LocationStore(SQLiteFile):
    """Places and the map in use; every method commits before returning."""

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

    # --- places ------------------------------------------------------------------------------

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
            insert_location(conn, location)
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
                (*_location_values(location), location_id),
            )
            conn.execute("DELETE FROM location_aliases WHERE location_id = ?", (location_id,))
            _insert_aliases(conn, location_id, location.aliases)
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
        location = valid_location(location)
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


def insert_location(conn: sqlite3.Connection, location: Location) -> None:
    """Insert an already checked place and its aliases (inside the caller's transaction)."""
    cursor = conn.execute(
        "INSERT INTO locations (name, map, x, y, heading, tolerance, crowded, pleasantness) "
        "VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
        _location_values(location),
    )
    assert cursor.lastrowid is not None
    _insert_aliases(conn, cursor.lastrowid, location.aliases)


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


def _insert_aliases(conn: sqlite3.Connection, location_id: int, aliases: Iterable[str]) -> None:
    conn.executemany(
        "INSERT INTO location_aliases (alias, location_id) VALUES (?, ?)",
        [(alias, location_id) for alias in aliases],
    )


def _number(value: object, what: str, default: float = 0.0) -> float:
    """A stored number hand-edited into nonsense becomes ``default`` (logged) instead of a crash."""
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    log.warning("%s is %r, not a finite number; using %s", what, value, default)
    return default
