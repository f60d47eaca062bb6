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
        self.connections: list[FullDiskConnection] = []
        # The file's connection, and a write-behind store's thread's own (ControllerStore).
        for attribute in ("_conn", "_write_conn"):
            if getattr(database, attribute, None) is None:
                continue
            getattr(database, attribute).close()
            conn = sqlite3.connect(
                database.path, isolation_level=None, factory=FullDiskConnection, check_same_thread=False
            )
            conn.execute("PRAGMA synchronous=FULL")
            setattr(database, attribute, conn)
            self.connections.append(conn)

    def fill(self) -> None:
        for conn in self.connections:
            conn.full = True

    def free(self) -> None:
        for conn in self.connections:
            conn.full = False
