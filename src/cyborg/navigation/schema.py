"""The navigation database's schema: its tables, the migrations between versions, and seeding a new file.

Called by :meth:`~cyborg.navigation.database.NavigationDatabase._prepare` each time a file
is opened, before any record store reads it. The schema version lives in ``PRAGMA
user_version``; an older file is migrated in one transaction, a new one (version 0, no
tables) is created and seeded with the shipped content (:mod:`~cyborg.navigation.content`).
A file that is broken or holds someone else's tables raises :class:`~cyborg.storage.Unusable`
(the caller moves it aside); one from a newer program raises DatabaseError and is left alone.
"""

from __future__ import annotations

import logging
import sqlite3
from collections.abc import Iterable
from pathlib import Path

from cyborg.errors import DatabaseError
from cyborg.navigation.content import DEFAULT_LOCATIONS, DEFAULT_RESPONSES
from cyborg.navigation.locations import insert_location
from cyborg.navigation.models import ResponseType
from cyborg.storage import Unusable, transaction

log = logging.getLogger(__name__)

_PLACEHOLDER = "map = '' AND x = 0 AND y = 0 AND heading = 0"
"""SQL: a row holding the (0, 0) placeholder pose that files before version 3 gave places on no map."""

# Each migration takes the file from version i to i + 1 (index i).
MIGRATIONS: tuple[tuple[str, ...], ...] = (
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
    (),  # version 4: only new sentences (ask_go: the robot confirms a command, thesis 7.7)
    (),  # version 5: only new sentences (did_you_mean: a place heard only roughly is asked about)
)
SCHEMA_VERSION = len(MIGRATIONS)
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

NEW_RESPONSE_TYPES: dict[int, tuple[ResponseType, ...]] = {
    2: (ResponseType.NOT_ON_MAP,),
    3: (ResponseType.NO_POSE, ResponseType.RESUME),
    4: (ResponseType.ASK_GO,),
    5: (ResponseType.DID_YOU_MEAN,),
}
"""Response types added by a schema version: migrating an older file adds their default sentences."""


def prepare(conn: sqlite3.Connection, path: Path, *, foreign_keys: bool) -> None:
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
            f"{path} has schema version {version}, newer than this program's {SCHEMA_VERSION}; "
            "fix: update cyborg, or point --db at another file"
        )
    if version == 0 and tables:
        raise Unusable(f"it holds other tables ({', '.join(sorted(tables))}) and no schema version")
    if version < SCHEMA_VERSION:
        _migrate(conn, path, version, foreign_keys=foreign_keys)
    _check_columns(conn)


def _migrate(conn: sqlite3.Connection, path: Path, version: int, *, foreign_keys: bool) -> None:
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
                for sql in MIGRATIONS[step]:
                    conn.execute(sql)
                if version > 0:
                    _seed_responses(conn, NEW_RESPONSE_TYPES.get(step + 1, ()))
            if version == 0:
                _seed(conn)
            broken = conn.execute("PRAGMA foreign_key_check").fetchall()
            if broken:
                raise sqlite3.IntegrityError(f"rows refer to missing ones: {broken[:3]}")
            conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
    except sqlite3.Error as exc:
        raise DatabaseError(
            f"could not migrate {path} from schema version {version} to {SCHEMA_VERSION}: {exc}; "
            "check the disk, or move the file away to start afresh"
        ) from exc
    finally:
        if foreign_keys:
            conn.execute("PRAGMA foreign_keys = ON")
    if version > 0:
        log.info(
            "navigation database %s migrated from schema version %d to %d",
            path,
            version,
            SCHEMA_VERSION,
        )
    if unplaced:
        log.warning(
            "navigation database %s: %s had the (0, 0) placeholder pose and no map; they have no pose "
            "now and are no targets until they get one: `cyborg db import-map MAP` (a map whose goals "
            "name them) or `cyborg db locations set-pose NAME --x X --y Y`",
            path,
            ", ".join(unplaced),
        )


def _check_columns(conn: sqlite3.Connection) -> None:
    for table, columns in _COLUMNS.items():
        found = {row[1] for row in conn.execute(f"PRAGMA table_info({table})")}
        if not columns <= found:
            raise Unusable(f"table {table} lacks columns {sorted(columns - found)}")


def _seed(conn: sqlite3.Connection) -> None:
    for location in DEFAULT_LOCATIONS:
        insert_location(conn, location)
    _seed_responses(conn, tuple(ResponseType))


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
