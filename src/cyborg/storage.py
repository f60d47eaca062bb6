"""SQLite files that never lose a committed write and survive being corrupted.

Shared by the controller's store and the navigation database: WAL journal with
``synchronous=FULL`` (a committed write survives a power cut), one
``BEGIN IMMEDIATE`` transaction per write, and recovery: a file that is not a
usable database is moved aside to ``<name>.corrupt-<time>`` with a logged
warning and started afresh, so the robot never crashes on it.

A write that fails (a full disk, an I/O error) raises :class:`NotSaved` and leaves
the file as it was; the file's :attr:`SQLiteFile.save_status` says so (and why) until
a write works again. Each such episode is logged once, and its end too.
"""

from __future__ import annotations

import fcntl
import logging
import os
import sqlite3
from collections.abc import Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path
from types import TracebackType
from typing import Self

from cyborg.errors import DatabaseError

log = logging.getLogger(__name__)


LOCK_FILE = "sim.lock"


@contextmanager
def lock_data_dir(folder: Path, what: str = "cyborg sim") -> Iterator[Path]:
    """Hold ``folder`` (created if missing) for this process while the block runs.

    Two robots on one data folder would overwrite each other's databases; the second one
    gets a DatabaseError naming the first one's process and the fix. The lock is an
    ``fcntl.flock`` on ``folder/sim.lock``, so it goes away with the process however it ends.
    """
    if folder.exists() and not folder.is_dir():
        raise DatabaseError(
            f"the data folder {folder} is a file, not a folder; fix: give a folder with --data-dir "
            "(it is created if missing)"
        )
    try:
        folder.mkdir(parents=True, exist_ok=True)
        handle = open(folder / LOCK_FILE, "a+", encoding="utf-8")  # noqa: SIM115 - held until the block ends
    except OSError as exc:
        raise DatabaseError(
            f"cannot use the data folder {folder}: {exc.strerror}; fix: give a writable folder with --data-dir"
        ) from exc
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "another process"
            raise DatabaseError(
                f"the data folder {folder} is in use by {holder}; fix: stop that one first, or give this "
                "one its own folder with --data-dir"
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"{what} (process {os.getpid()})\n")
        handle.flush()
        try:
            yield folder
        finally:
            handle.seek(0)
            handle.truncate()
            fcntl.flock(handle, fcntl.LOCK_UN)


class Unusable(DatabaseError):
    """The file exists but cannot be used as this database (reason in args[0]).

    Raised while opening; :class:`SQLiteFile` moves such a file aside and starts afresh.
    """


class NotSaved(DatabaseError):
    """A write failed and stored nothing: the file holds what it held before (why and the fix in the text)."""


@dataclass(frozen=True)
class SaveStatus:
    """Whether the writes to a database work, for status reports (``saved`` false: why and the fix)."""

    path: str
    saved: bool
    problem: str | None = None
    """The first failed write of this episode and its error, e.g. 'could not save the PAD values
    in /data/controller.db: database or disk is full'."""
    fix: str | None = None
    failed_writes: int = 0
    """Writes that failed since the last one that worked."""
    unsaved: tuple[str, ...] = ()
    """What is kept in memory until it can be written (see ControllerStore)."""

    def as_json(self) -> dict[str, object]:
        data = asdict(self)
        data["unsaved"] = list(self.unsaved)
        return data


@contextmanager
def transaction(conn: sqlite3.Connection) -> Iterator[None]:
    """One write: committed as a whole, or (on any error, also a failed COMMIT) not at all."""
    conn.execute("BEGIN IMMEDIATE")
    try:
        yield
        conn.execute("COMMIT")
    except BaseException:
        if conn.in_transaction:  # SQLite itself rolls back on a full disk or an I/O error
            with suppress(sqlite3.Error):
                conn.execute("ROLLBACK")
        raise


class SQLiteFile:
    """Base class: opens ``path`` (recovering a broken file), then lets ``_prepare`` check or create it."""

    what = "database"  # how log lines and errors name the file, e.g. "navigation database"
    foreign_keys = False

    def __init__(self, path: str | Path, *, recover: bool = True) -> None:
        """``recover``: move an unusable file aside and start afresh (the robot's own files); False
        for a path the user named (``cyborg db --db``, a module's ``db:``): refuse it, touching nothing."""
        self.path = Path(path)
        self.recover = recover
        self._identity: tuple[int, int] | None = None  # of the file opened: a write checks it is still there
        self._failure: tuple[str, str] | None = None  # (problem, fix) of the first failed write of an episode
        self._failed_writes = 0
        self._conn = self._open_or_recover()
        self._identity = _identity(self.path)

    def _prepare(self, conn: sqlite3.Connection) -> None:
        """Check, migrate or create the schema; raise :class:`Unusable` for a foreign or broken file."""
        raise NotImplementedError

    # --- opening ----------------------------------------------------------------------------

    def _open_or_recover(self) -> sqlite3.Connection:
        if self.path.is_dir():
            raise DatabaseError(f"{self.path} is a folder; give a file name such as cyborg.db")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise DatabaseError(
                f"cannot create the folder of {self.path}: {exc}; pick a writable path"
            ) from exc
        try:
            return self._open()
        except Unusable as exc:
            if isinstance(exc.__cause__, sqlite3.Error) and _disk_trouble(exc.__cause__):
                raise DatabaseError(
                    f"cannot use {self.path}: {exc.__cause__}; fix: free some space on that disk "
                    "(or give another folder with --data-dir)"
                ) from exc
            if not self.recover:
                raise DatabaseError(
                    f"{self.path} is not a usable {self.what} ({exc.args[0]}); it was left as it is; fix: give "
                    f"the path of a {self.what} (or a new file name, to start one)"
                ) from None
            self._move_aside(str(exc.args[0]))
        try:
            return self._open()
        except Unusable as exc:
            raise DatabaseError(f"cannot create {self.path}: {exc.args[0]}") from exc

    def _open(self) -> sqlite3.Connection:
        conn = self._connect()
        try:
            self._prepare(conn)
        except sqlite3.DatabaseError as exc:
            conn.close()
            raise Unusable(str(exc)) from exc
        except BaseException:
            conn.close()
            raise
        return conn

    def _connect(self, *, any_thread: bool = False) -> sqlite3.Connection:
        """A connection in WAL mode, synchronous=FULL; ``any_thread``: usable by one other thread."""
        try:
            conn = sqlite3.connect(self.path, isolation_level=None, check_same_thread=not any_thread)
        except sqlite3.Error as exc:
            raise DatabaseError(f"cannot open {self.path}: {exc}; check the file's permissions") from exc
        try:
            conn.execute("PRAGMA journal_mode=WAL")
            conn.execute("PRAGMA synchronous=FULL")
            if self.foreign_keys:
                conn.execute("PRAGMA foreign_keys=ON")
        except sqlite3.OperationalError as exc:
            conn.close()
            holders = holders_of(self.path) if _locked(exc) else []
            if _disk_trouble(exc):
                fix = "free some space on that disk (or give another folder with --data-dir)"
            elif holders:
                fix = f"stop the program that holds it ({'; '.join(holders)}), or let it finish, then retry"
            else:
                fix = "check permissions and that no other program locks it"
            raise DatabaseError(f"cannot use {self.path}: {exc}; fix: {fix}") from exc
        except sqlite3.DatabaseError as exc:
            conn.close()
            raise Unusable(f"not an SQLite database ({exc})") from exc
        return conn

    @staticmethod
    def check_integrity(conn: sqlite3.Connection) -> None:
        check = conn.execute("PRAGMA integrity_check").fetchall()
        if check != [("ok",)]:
            raise Unusable(f"integrity_check failed: {check[:3]}")

    def _move_aside(self, reason: str) -> None:
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
        target = self.path.with_name(f"{self.path.name}.corrupt-{stamp}")
        n = 1
        while target.exists():
            target = self.path.with_name(f"{self.path.name}.corrupt-{stamp}-{n}")
            n += 1
        try:
            self.path.rename(target)
            for suffix in ("-wal", "-shm"):
                side = self.path.with_name(self.path.name + suffix)
                if side.exists():
                    side.rename(target.with_name(target.name + suffix))
        except OSError as exc:
            raise DatabaseError(
                f"{self.path} is unusable ({reason}) and could not be moved aside: {exc}; move it by hand"
            ) from exc
        log.warning(
            "%s %s is unusable (%s); moved it to %s and started afresh", self.what, self.path, reason, target
        )

    # --- reading and writing -------------------------------------------------------------------

    @property
    def save_status(self) -> SaveStatus:
        """Whether writes work; if not, the first failed write of the episode and the fix."""
        if self._failure is None:
            return SaveStatus(str(self.path), saved=True)
        problem, fix = self._failure
        return SaveStatus(str(self.path), False, problem, fix, self._failed_writes)

    @contextmanager
    def _writing(self, what: str, conn: sqlite3.Connection | None = None) -> Iterator[sqlite3.Connection]:
        """One write transaction (on ``conn``, else the file's connection); a failure raises
        :class:`NotSaved` (logged once per episode)."""
        conn = self._conn if conn is None else conn
        try:
            with transaction(conn):
                yield conn
        except sqlite3.Error as exc:
            raise self._write_failed(what, exc) from exc
        if self._identity is not None and _identity(self.path) != self._identity:
            raise self._vanished(what)
        if self._failure is not None:
            log.warning(
                "%s %s: writes work again, after %d failed writes (the first: %s)",
                self.what,
                self.path,
                self._failed_writes,
                self._failure[0],
            )
            self._failure, self._failed_writes = None, 0

    def _write_failed(self, what: str, exc: sqlite3.Error) -> NotSaved:
        problem = f"could not {what} in {self.path}: {exc}"
        if _disk_trouble(exc):
            fix = "free some space on that disk (or give another folder with --data-dir)"
        elif _locked(exc):
            holders = holders_of(self.path)
            problem += f" (held by {'; '.join(holders)})" if holders else ""
            fix = (
                "stop that program, or let it finish, then retry"
                if holders
                else "find the program that holds it (fuser -v FILE), stop it or let it finish, then retry"
            )
        else:
            fix = "check the disk and the file's permissions"
        return self._failed(problem, fix)

    def _vanished(self, what: str) -> NotSaved:
        problem = (
            f"could not {what}: {self.path} was deleted or replaced while in use (its data folder removed?), "
            "so what is written goes to a file nobody can open"
        )
        fix = "restore the data folder, then restart the robot (it keeps what it knows in memory meanwhile)"
        return self._failed(problem, fix)

    def _failed(self, problem: str, fix: str) -> NotSaved:
        self._failed_writes += 1
        if self._failure is None:
            self._failure = (problem, fix)
            log.warning(
                "%s: %s; fix: %s (further failed writes are not logged; a line says when writes work again)",
                self.what,
                problem,
                fix,
            )
        return NotSaved(f"{problem}; fix: {fix}")

    def _read(self, sql: str, params: Sequence[object] = ()) -> list[tuple[object, ...]]:
        try:
            return self._conn.execute(sql, tuple(params)).fetchall()
        except sqlite3.Error as exc:
            raise DatabaseError(
                f"could not read {self.path}: {exc}; reopen the database to recover it"
            ) from exc

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, value: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def _identity(path: Path) -> tuple[int, int] | None:
    """(device, inode) of the file at ``path``; None if there is none."""
    try:
        status = path.stat()
    except OSError:
        return None
    return status.st_dev, status.st_ino


def _locked(exc: sqlite3.Error) -> bool:
    code = getattr(exc, "sqlite_errorcode", 0) & 0xFF
    return code in (sqlite3.SQLITE_BUSY, sqlite3.SQLITE_LOCKED) or "locked" in str(exc)


def holders_of(path: Path) -> list[str]:
    """Other processes that have ``path`` open, as 'NAME (process PID)'; [] where /proc cannot tell."""
    try:
        target = path.resolve()
        processes = list(Path("/proc").iterdir())
    except OSError:
        return []
    found: list[str] = []
    for process in processes:
        if not process.name.isdigit() or int(process.name) == os.getpid():
            continue
        try:
            opened = any(Path(os.readlink(fd)) == target for fd in (process / "fd").iterdir())
            if opened:
                command = " ".join(
                    (process / "cmdline").read_bytes().decode(errors="replace").replace("\0", " ").split()
                )
                found.append(f"{command[:80] or process.name} (process {process.name})")
        except OSError:
            continue
    return found


def _disk_trouble(exc: sqlite3.Error) -> bool:
    """A full disk or an I/O error: the file is fine, the disk is not (never move it aside then)."""
    code = getattr(exc, "sqlite_errorcode", 0) & 0xFF
    return code in (sqlite3.SQLITE_FULL, sqlite3.SQLITE_IOERR)
