"""The navigation module's database: known places, scheduled visits and things to say (SQLite).

The facade of the navigation package's persistence: :class:`NavigationDatabase` is the
one object the module, the ``cyborg db`` command and the composition root (:mod:`cyborg.app`)
hold. It combines the record stores, each of one table group, on one SQLite file:

* :mod:`~cyborg.navigation.locations`: places (name, aliases, pose on a map or none yet,
  arrival tolerance, crowded, pleasantness) and the map in use (only places with a pose on
  it are targets);
* :mod:`~cyborg.navigation.events`: calendar events at places, optionally recurring
  (:mod:`~cyborg.navigation.recurrence`), with a UID so an .ics import
  (:mod:`~cyborg.navigation.ics`) updates;
* :mod:`~cyborg.navigation.responses`: sentences with the placeholder ``LOCATION``, by
  response type and emotion (no emotion = fits any emotion);

and :mod:`~cyborg.navigation.map_import` turns a map's goal poses into places. The value
types are in :mod:`~cyborg.navigation.models`.

A missing file is created by :mod:`~cyborg.navigation.schema` and seeded with the places
and sentences of ``navigation/data/*.yaml`` (:mod:`~cyborg.navigation.content`). A file
that is not a database, fails ``PRAGMA integrity_check`` or holds someone else's tables is
moved aside to ``<name>.corrupt-<timestamp>`` with a warning and recreated, so the robot
always starts. Writes are committed at once (WAL, synchronous=FULL). The schema version
lives in ``PRAGMA user_version`` and older files are migrated on open.
"""

from __future__ import annotations

import sqlite3
from typing import Any

from cyborg.navigation import map_import, schema
from cyborg.navigation.events import EventStore
from cyborg.navigation.models import CalendarEvent
from cyborg.navigation.responses import ResponseStore

__all__ = ["CalendarEvent", "NavigationDatabase"]


class NavigationDatabase(EventStore, ResponseStore):
    """The SQLite file of the navigation module; every method commits before returning."""

    what = "navigation database"
    foreign_keys = True

    def _prepare(self, conn: sqlite3.Connection) -> None:
        """Check the file, migrate it to the current schema version and seed a new one."""
        schema.prepare(conn, self.path, foreign_keys=self.foreign_keys)

    def import_pose(self, pose: Any, map_name: str) -> str:
        """Add or update one location from a map pose (see :func:`~cyborg.navigation.map_import.import_pose`)."""
        return map_import.import_pose(self, pose, map_name)
