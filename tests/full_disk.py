"""A database file whose disk fills up on demand, for tests of a robot that cannot save.

Every COMMIT then fails as SQLite's does on a full disk (checked on a real 200 KiB tmpfs):
``sqlite3.OperationalError('database or disk is full')`` with error code SQLITE_FULL, after
SQLite has rolled the transaction back. Reads keep working, as they do on a full disk.
"""

from __future__ import annotations

import sqlite3
from typing import Any

from cyborg.storage import SQLiteFile


class FullDiskConnection(sqlite3.Connection):
    full = False

    def execute(self, sql: str, parameters: Any = (), /) -> sqlite3.Cursor:
        if self.full and sql.strip().upper() == "COMMIT":
            super().execute("ROLLBACK")
            error = sqlite3.OperationalError("database or disk is full")
            error.sqlite_errorcode = sqlite3.SQLITE_FULL  # type: ignore[attr-defined]
            error.sqlite_errorname = "SQLITE_FULL"  # type: ignore[attr-defined]
            raise error
        return super().execute(sql, parameters)


class Disk:
    """The disk under ``database``: ``fill()`` makes every write fail, ``free()`` makes room again."""

    def __init__(self, database: SQLiteFile) -> None:
        database._conn.close()
        self.conn = sqlite3.connect(database.path, isolation_level=None, factory=FullDiskConnection)
        self.conn.execute("PRAGMA synchronous=FULL")
        database._conn = self.conn

    def fill(self) -> None:
        self.conn.full = True

    def free(self) -> None:
        self.conn.full = False
