"""Persistent state of the controller core's emotion system and motivator (SQLite).

One file holds the PAD point and when it was last updated (wall time, seconds),
the emotion system's on/off switch, the motivator's saturations and its table of
motivational events. Every write is committed at once (WAL, synchronous=FULL),
so a crash loses at most the write in flight.

With ``write_behind`` (the controller's store, as the composition root builds it) the
emotion, the switch and the saturations are committed by a thread of the store's own, so the
controller's loop never waits for the disk's flush (1-3 ms a commit on the lab machine, more
on a busy disk); what waits is latest-value-wins, so a burst of saves is one commit. With a
``commit_window`` (the composition root gives ``COMMIT_WINDOW``, 20 ms of real time, only to a
virtual clock that runs as fast as it can) the thread starts a commit that long after the first
save that waits for it, so the saves of that moment share it: at most 50 commits a second however
fast the clock runs (each commit takes the interpreter's lock from the loop). Without one (a real
robot, ROS launches) each save is committed at once, so a crash loses at most the write in
flight. Reads of those values first wait for the writes queued
before them (without waiting out the window), and closing writes everything.

A missing file is created with defaults (events seeded from the caller's list);
a file that is not a database, fails ``PRAGMA integrity_check`` or has another
schema is moved aside to ``<name>.corrupt-<timestamp>`` with a warning and
recreated, so the controller always starts.

While writes fail (a full disk), the emotion, its switch and the saturations are
kept in memory, reported in :attr:`ControllerStore.save_status`, and written as soon
as a write works: at the next save, and every ``SAVE_RETRY`` seconds on the given clock.
"""

from __future__ import annotations

import logging
import math
import sqlite3
import threading
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import suppress
from dataclasses import replace
from pathlib import Path

from pydantic import ValidationError

from cyborg.emotion.model import DIMENSIONS, PAD, clamp
from cyborg.emotion.system import StoredEmotion
from cyborg.errors import DatabaseError, InvalidValueError
from cyborg.motivator.logic import MotivationalEvent
from cyborg.storage import NotSaved, SaveStatus, SQLiteFile, Unusable, transaction
from cyborg.transport.clock import Clock, Periodic

log = logging.getLogger(__name__)

SCHEMA_VERSION = "1"
SAVE_RETRY = 1.0
"""Clock seconds between tries to write what a failed write left unsaved."""
COMMIT_WINDOW = 0.02
"""Real seconds the write-behind thread gathers saves before it commits them together, on a
virtual clock that runs as fast as it can (``ControllerStore(commit_window=...)``; default 0)."""

_TABLES: dict[str, str] = {
    "meta": "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    "emotion": (
        "CREATE TABLE emotion (id INTEGER PRIMARY KEY CHECK (id = 1), "
        "pleasure REAL NOT NULL, arousal REAL NOT NULL, dominance REAL NOT NULL, "
        "updated_at REAL, enabled INTEGER NOT NULL)"
    ),
    "saturations": "CREATE TABLE saturations (event TEXT PRIMARY KEY, value REAL NOT NULL)",
    "events": (
        "CREATE TABLE events (state TEXT NOT NULL, event TEXT NOT NULL, "
        "reward_pleasure REAL NOT NULL, reward_arousal REAL NOT NULL, "
        "reward_dominance REAL NOT NULL, event_cost REAL, PRIMARY KEY (state, event))"
    ),
}
_COLUMNS: dict[str, list[str]] = {
    "meta": ["key", "value"],
    "emotion": ["id", "pleasure", "arousal", "dominance", "updated_at", "enabled"],
    "saturations": ["event", "value"],
    "events": [
        "state",
        "event",
        "reward_pleasure",
        "reward_arousal",
        "reward_dominance",
        "event_cost",
    ],
}


Write = Callable[[sqlite3.Connection], object]


class ControllerStore(SQLiteFile):
    """The SQLite file behind the emotion system and the motivator.

    The emotion, the switch and the saturations are saved latest-value-wins: a save that fails
    does not raise but keeps the value (True means stored, False kept in memory), and
    :meth:`write_pending` writes what is kept; with a ``clock`` it is tried every SAVE_RETRY s.
    """

    what = "controller store"

    def __init__(
        self,
        path: str | Path,
        seed_events: Sequence[MotivationalEvent] = (),
        *,
        clock: Clock | None = None,
        write_behind: bool = False,
        commit_window: float = 0.0,
    ) -> None:
        if not (math.isfinite(commit_window) and commit_window >= 0):
            raise InvalidValueError(
                f"commit_window {commit_window!r} is not a number of seconds >= 0; fix: pass e.g. 0.02"
            )
        self._seed = list(seed_events)
        self.clock = clock
        self._pending: dict[str, Write] = {}  # what is not stored yet (its name) -> how to write it
        self._retry: Periodic | None = None
        self._pending_lock = threading.Lock()  # held for a moment: _pending and _queued
        self._queued = False  # a write-behind job waits to start
        self._commit_window = commit_window
        self._hurry = threading.Event()  # set: the waiting job commits now (a read or closing waits for it)
        self._events: tuple[object, list[MotivationalEvent]] | None = None  # (data_version, events)
        self._writer = ThreadPoolExecutor(1, thread_name_prefix="controller-store") if write_behind else None
        super().__init__(path)
        # The thread's own connection: in WAL mode the loop's reads never wait for its commits.
        self._write_conn = self._connect(any_thread=True) if write_behind else None

    # --- saving what a failed write left in memory ---------------------------------------

    @property
    def save_status(self) -> SaveStatus:
        status = super().save_status
        with self._pending_lock:
            unsaved = tuple(self._pending) if not status.saved or self._writer is None else ()
        return replace(status, saved=status.saved and not unsaved, unsaved=unsaved)

    def _save_latest(self, name: str, write: Write) -> bool:
        with self._pending_lock:
            self._pending.pop(name, None)
            self._pending[name] = write  # (last in the order of the pending ones)
        return self.write_pending()

    def write_pending(self) -> bool:
        """Write what is kept in memory; True when everything is stored (with ``write_behind``:
        hands it to the store's thread and says whether writes worked so far)."""
        if self._writer is not None:
            self._write_behind()
            return self.save_status.saved
        stored = self._write_kept()
        self._after_write(stored)
        return stored

    def flush(self) -> None:
        """Wait until the writes handed to the store's thread are done (at once without ``write_behind``)."""
        if self._writer is not None:
            self._hurry.set()
            self._writer.submit(lambda: None).result()

    def _write_behind(self) -> None:
        with self._pending_lock:
            if self._queued or not self._pending or self._writer is None:
                return
            self._queued = True
        self._writer.submit(self._write_job)

    def _write_job(self) -> None:
        """On the store's thread: gather saves for the commit window, write what waits, then tell
        the loop (retries go by its clock)."""
        if self._commit_window and self._hurry.wait(self._commit_window):
            self._hurry.clear()
        with self._pending_lock:
            self._queued = False
        stored = self._write_kept()
        clock = self.clock
        if clock is not None and (not stored or self._retry is not None):
            with suppress(RuntimeError):  # the loop is closed: nothing to retry on
                clock.loop.call_soon_threadsafe(self._after_write, stored)

    def _write_kept(self) -> bool:
        """Write what waits in one transaction; what fails stays unless a newer value came."""
        with self._pending_lock:
            batch, self._pending = self._pending, {}
        if not batch:
            return True
        try:
            with self._writing("save " + " and ".join(batch), self._write_conn) as conn:
                for write in batch.values():
                    write(conn)
        except NotSaved:  # logged once per episode by _writing; the status says it
            with self._pending_lock:
                self._pending = {**batch, **self._pending}
            return False
        return True

    def _after_write(self, stored: bool) -> None:
        """On the loop: retry every SAVE_RETRY s on the clock while writes fail; stop when they work."""
        if not stored and self.clock is not None and self._retry is None:
            self._retry = self.clock.every(
                SAVE_RETRY, self.write_pending, name=f"saving the {self.what}", logger=log
            )
        elif stored and self._retry is not None and not self._pending:
            self._retry.cancel()
            self._retry = None

    def close(self) -> None:
        """Write what is kept in memory (a last try), then close; what cannot be written is logged."""
        self.clock = None  # no more tries after this one
        if self._retry is not None:
            self._retry.cancel()
            self._retry = None
        if self._writer is not None:
            self._hurry.set()
            self._writer.shutdown(wait=True)
            self._writer = None
        if not self.write_pending():
            log.warning(
                "%s %s closed with %s not saved: %s",
                self.what,
                self.path,
                " and ".join(self._pending),
                self.save_status.problem,
            )
        super().close()
        if self._write_conn is not None:
            self._write_conn.close()

    def _prepare(self, conn: sqlite3.Connection) -> None:
        tables = {row[0] for row in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if not tables:
            self._create(conn)
            return
        self.check_integrity(conn)
        if "meta" in tables:  # before the columns: a newer program's file is not broken, only newer
            row = conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
            version = str(row[0]) if row is not None else ""
            if version.isdigit() and int(version) > int(SCHEMA_VERSION):
                raise DatabaseError(
                    f"{self.path} has schema version {version}, newer than this program's {SCHEMA_VERSION}; "
                    "fix: update cyborg, or give --data-dir another folder"
                )
        for table, columns in _COLUMNS.items():
            found = [row[1] for row in conn.execute(f"PRAGMA table_info({table})")]
            if found != columns:
                raise Unusable(f"table {table} has columns {found}, expected {columns}")
        if conn.execute("SELECT COUNT(*) FROM emotion").fetchone()[0] != 1:
            raise Unusable("the emotion row is missing")

    def _create(self, conn: sqlite3.Connection) -> None:
        with transaction(conn):
            for sql in _TABLES.values():
                conn.execute(sql)
            conn.execute("INSERT INTO meta VALUES ('schema_version', ?)", (SCHEMA_VERSION,))
            conn.execute("INSERT INTO emotion VALUES (1, 0.0, 0.0, 0.0, NULL, 1)")
            for event in self._seed:
                self._upsert_event(conn, event)

    # --- emotion ---------------------------------------------------------------------

    def get_emotion(self) -> StoredEmotion:
        self.flush()
        [(p, a, d, updated_at, enabled)] = self._read(
            "SELECT pleasure, arousal, dominance, updated_at, enabled FROM emotion"
        )
        values = [clamp(_finite(x, f"stored {dim}")) for x, dim in zip((p, a, d), DIMENSIONS, strict=True)]
        when = updated_at if isinstance(updated_at, int | float) and math.isfinite(updated_at) else None
        return StoredEmotion(PAD.of(values), when, bool(enabled))

    def save_emotion(self, pad: PAD, updated_at: float) -> bool:
        """Store the PAD values; False if they are kept in memory for now (see the class)."""
        values = (*pad.as_tuple(), updated_at)
        sql = "UPDATE emotion SET pleasure = ?, arousal = ?, dominance = ?, updated_at = ?"
        return self._save_latest("the PAD values", lambda conn: conn.execute(sql, values))

    def set_emotion_enabled(self, enabled: bool) -> bool:
        """Store the on/off switch; False if it is kept in memory for now (see the class)."""
        value = int(enabled)
        return self._save_latest(
            "the emotion system's switch",
            lambda conn: conn.execute("UPDATE emotion SET enabled = ?", (value,)),
        )

    # --- saturations -----------------------------------------------------------------

    def get_saturations(self) -> dict[str, float]:
        self.flush()
        rows = self._read("SELECT event, value FROM saturations ORDER BY event")
        return {str(name): max(0.0, min(1.0, _finite(v, f"saturation of {name}"))) for name, v in rows}

    def save_saturations(self, saturations: Mapping[str, float]) -> bool:
        """Replace all saturations with ``saturations``; False if kept in memory for now (see the class)."""
        rows = sorted(saturations.items())

        def write(conn: sqlite3.Connection) -> None:
            conn.execute("DELETE FROM saturations")
            conn.executemany("INSERT INTO saturations VALUES (?, ?)", rows)

        return self._save_latest("the motivator's saturations", write)

    # --- motivational events -------------------------------------------------------------

    def list_events(self, state: str | None = None) -> list[MotivationalEvent]:
        """The motivational events (of ``state``), sorted by state and name.

        Read again whenever the file changed (another program may edit the table while the robot
        runs; SQLite's ``data_version`` says so), else taken from what was read last: the
        motivator asks at every decision."""
        [(version,)] = self._read("PRAGMA data_version")
        if self._events is None or self._events[0] != version:
            self._events = (version, self._read_events())
        return [e for e in self._events[1] if state is None or e.state == state]

    def _read_events(self) -> list[MotivationalEvent]:
        events = []
        for row in self._read("SELECT * FROM events ORDER BY state, event"):
            try:
                row_data = dict(zip(_COLUMNS["events"], row, strict=True))
                events.append(MotivationalEvent.model_validate(row_data))
            except ValidationError as exc:
                log.warning("skipping invalid motivational event row %s in %s: %s", row, self.path, exc)
        return events

    def add_event(self, event: MotivationalEvent) -> None:
        """Add ``event``, replacing any event of the same name in the same state."""
        with self._writing(f"add event {event.event!r}") as conn:
            self._upsert_event(conn, event)
        self._events = None  # (this connection's own writes leave data_version alone)
        self.write_pending()

    def remove_event(self, state: str, event: str) -> bool:
        """Remove an event; False if there was none of that name in that state."""
        with self._writing(f"remove event {event!r}") as conn:
            cursor = conn.execute("DELETE FROM events WHERE state = ? AND event = ?", (state, event))
        self._events = None
        self.write_pending()
        return cursor.rowcount > 0

    @staticmethod
    def _upsert_event(conn: sqlite3.Connection, event: MotivationalEvent) -> None:
        conn.execute(
            "INSERT OR REPLACE INTO events VALUES (?, ?, ?, ?, ?, ?)",
            (
                event.state,
                event.event,
                event.reward_pleasure,
                event.reward_arousal,
                event.reward_dominance,
                event.event_cost,
            ),
        )


def _finite(value: object, what: str) -> float:
    """A stored number hand-edited into nonsense becomes 0 (logged) rather than a crash."""
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    log.warning("%s is %r, not a finite number; using 0.0", what, value)
    return 0.0
