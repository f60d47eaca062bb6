"""The calendar events of the navigation database (table ``events``) and how their time zones are stored.

One of the record stores that :class:`~cyborg.navigation.database.NavigationDatabase`
combines; it builds on :class:`~cyborg.navigation.locations.LocationStore` (an event is at
a known place) and leaves recurrence to :mod:`~cyborg.navigation.recurrence`. Times are
stored in UTC with the zone of the start (an IANA key, 'UTC' or a fixed offset), so a
weekly event at 15:00 Europe/Oslo comes back in its own zone.
"""

from __future__ import annotations

import logging
import re
import sqlite3
from collections.abc import Sequence
from dataclasses import replace
from datetime import UTC, datetime, timedelta, timezone, tzinfo
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from cyborg.errors import CalendarError, DatabaseError
from cyborg.navigation.locations import LocationStore
from cyborg.navigation.models import CalendarEvent, Occurrence
from cyborg.navigation.recurrence import normalise_recurrence, occurrences_between

log = logging.getLogger(__name__)


class EventStore(LocationStore):
    """Calendar events at the known places; every method commits before returning."""

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
                (*_event_values(event), event_id),
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
                    (*_event_values(event), existing),
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
                raise CalendarError(f"{label}={moment.isoformat()} is naive; pass an aware datetime")
        return occurrences_among(self.list_events(include_ignored=False), window_start, window_end)

    def ongoing_events(self, now: datetime) -> list[Occurrence]:
        """Occurrences of non-ignored events with ``start <= now < end`` (recurring ones expanded)."""
        return ongoing_among(self.list_events(include_ignored=False), now)

    def _event_id_by_uid(self, uid: str) -> int | None:
        rows = self._read("SELECT id FROM events WHERE uid = ?", (uid,))
        return int(str(rows[0][0])) if rows else None

    def _insert_event(self, conn: sqlite3.Connection, event: CalendarEvent) -> CalendarEvent:
        cursor = conn.execute(
            "INSERT INTO events (location_id, start_utc, end_utc, timezone, ignored, recurrence, summary, uid) "
            "VALUES ((SELECT id FROM locations WHERE name = ?), ?, ?, ?, ?, ?, ?, ?)",
            _event_values(event),
        )
        return replace(event, id=cursor.lastrowid)

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


def occurrences_among(
    events: Sequence[CalendarEvent], window_start: datetime, window_end: datetime
) -> list[Occurrence]:
    """Occurrences of ``events`` overlapping ``[window_start, window_end)``, by start (no database:
    a thread may expand them while the loop goes on; every expansion is bounded, see recurrence)."""
    found = [
        Occurrence(event, start, end)
        for event in events
        for start, end in occurrences_between(
            event.start, event.end, event.recurrence, window_start, window_end
        )
    ]
    return sorted(found, key=lambda occ: (occ.start, occ.event.id or 0))


def ongoing_among(events: Sequence[CalendarEvent], now: datetime) -> list[Occurrence]:
    """Occurrences of ``events`` with ``start <= now < end``."""
    if now.tzinfo is None:
        raise CalendarError(
            f"now={now.isoformat()} is naive; pass an aware time, e.g. datetime.now(timezone.utc)"
        )
    return [
        occ for occ in occurrences_among(events, now, now + timedelta(microseconds=1)) if occ.start <= now
    ]


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
