"""Importing ``.ics`` files (RFC 5545 calendars) into the navigation database.

``import_ics`` reads the file's VEVENTs with ``icalendar``, matches each event's LOCATION (or
SUMMARY) to a known place, keeps its RRULE, EXDATE and RDATE as the event's recurrence
(:mod:`cyborg.navigation.recurrence` checks and expands it) and stores the events, updating
those whose UID is already there. Events it cannot use are reported with the reason, not raised.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import date, datetime, time, timedelta, tzinfo
from pathlib import Path
from typing import Any, Protocol
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

import icalendar

from cyborg.errors import CalendarError, DatabaseError
from cyborg.limits import MAX_EVENT_DAYS, MAX_ICS_BYTES
from cyborg.navigation.keywords import LocationMatcher
from cyborg.navigation.models import CalendarEvent, Location
from cyborg.navigation.recurrence import utc_stamp

DEFAULT_TIMEZONE = "Europe/Oslo"
"""Zone of the Cyborg (Trondheim): used for floating times and all-day events in .ics files."""


class EventBook(Protocol):
    """What :func:`import_ics` needs of the database: places, and checking and storing events.

    :class:`~cyborg.navigation.database.NavigationDatabase` is one; the import uses nothing else of it.
    """

    def get_location(self, name_or_alias: str) -> Location: ...

    def matcher(self, threshold: float | None = None, *, on_map: bool = False) -> LocationMatcher: ...

    def validate_event(self, event: CalendarEvent) -> CalendarEvent: ...

    def upsert_events(self, events: Sequence[CalendarEvent]) -> list[tuple[CalendarEvent, bool]]: ...


@dataclass(frozen=True)
class SkippedEvent:
    """A VEVENT that was not imported, and why."""

    summary: str
    reason: str


@dataclass
class ImportReport:
    """What ``import_ics`` did: events added, events updated (same UID) and events skipped."""

    added: list[CalendarEvent] = field(default_factory=list)
    updated: list[CalendarEvent] = field(default_factory=list)
    skipped: list[SkippedEvent] = field(default_factory=list)


def import_ics(
    db: EventBook,
    path: str | Path,
    default_location: str | None = None,
    *,
    local_tz: str = DEFAULT_TIMEZONE,
) -> ImportReport:
    """Import the VEVENTs of an .ics file into ``db``; re-importing updates events by UID.

    Each event's LOCATION, else its SUMMARY, is matched (tolerantly) to a known place;
    ``default_location`` is used when neither names one. Floating times and all-day
    events are read in ``local_tz``. Events that cannot be used are reported, not raised.
    """
    if default_location is not None:
        default_location = db.get_location(default_location).name
    zone = _zone(local_tz)
    calendar = _read_calendar(Path(path))
    matcher = db.matcher()
    report = ImportReport()
    pending: dict[str, CalendarEvent] = {}
    for vevent in calendar.walk("VEVENT"):
        summary = str(vevent.get("SUMMARY", "")).strip()
        try:
            event = _convert(vevent, matcher, default_location, zone)
            event = db.validate_event(event)
            assert event.uid is not None
            if event.uid in pending:
                raise CalendarError(
                    f"UID {event.uid!r} appears twice in the file; the first one was imported"
                )
        except (ValueError, DatabaseError) as exc:
            report.skipped.append(SkippedEvent(summary or "(no summary)", str(exc)))
            continue
        pending[event.uid] = event
    for event, created in db.upsert_events(list(pending.values())):
        (report.added if created else report.updated).append(event)
    return report


def _zone(name: str) -> ZoneInfo:
    try:
        return ZoneInfo(name)
    except (ZoneInfoNotFoundError, ValueError) as exc:
        raise DatabaseError(f"unknown time zone {name!r}; use an IANA name such as Europe/Oslo") from exc


def _read_calendar(path: Path) -> icalendar.Calendar:
    try:
        with path.open("rb") as handle:
            data = handle.read(MAX_ICS_BYTES + 1)
    except OSError as exc:
        raise DatabaseError(f"cannot read {path}: {exc.strerror}; fix: check the file name") from exc
    if len(data) > MAX_ICS_BYTES:
        raise DatabaseError(
            f"{path} is over the limit of {MAX_ICS_BYTES:,} bytes; fix: export a shorter period of the calendar"
        )
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DatabaseError(
            f"{path} is not UTF-8 text (byte {data[exc.start]:#04x} at offset {exc.start}); fix: export the "
            "calendar again as UTF-8 .ics (RFC 5545 requires UTF-8)"
        ) from None
    try:
        return icalendar.Calendar.from_ical(data)
    except (ValueError, RecursionError) as exc:
        raise DatabaseError(
            f"{path} is not an iCalendar file ({_short(str(exc))}); fix: export the calendar again as .ics"
        ) from exc


def _convert(
    vevent: Any,
    matcher: LocationMatcher,
    default_location: str | None,
    zone: ZoneInfo,
) -> CalendarEvent:
    """One VEVENT as an (unchecked) CalendarEvent; CalendarError says why it cannot be imported."""
    if vevent.get("RECURRENCE-ID") is not None:
        raise CalendarError("it changes one occurrence of a recurring event, which is not supported")
    if str(vevent.get("STATUS", "")).upper() == "CANCELLED":
        raise CalendarError("it is cancelled")
    start, end = _times(vevent, zone)
    summary = str(vevent.get("SUMMARY", "")).strip() or None
    place_text = str(vevent.get("LOCATION", "")).strip()
    location = _place(matcher, place_text, summary, default_location)
    recurrence = _recurrence(vevent, start)
    uid = str(vevent.get("UID", "")).strip() or _synthetic_uid(start, summary, place_text)
    return CalendarEvent(location, start, end, recurrence=recurrence, summary=summary, uid=uid)


def _as_aware(value: date | datetime, zone: ZoneInfo) -> datetime:
    if not isinstance(value, datetime):
        return datetime.combine(value, time(0), zone)
    if value.tzinfo is None:
        return value.replace(tzinfo=zone)
    if isinstance(value.tzinfo, ZoneInfo) or value.utcoffset() == timedelta(0):
        return value
    # A custom VTIMEZONE: the Cyborg's own zone keeps recurrences on local time.
    return value.astimezone(zone)


def _check_zone(name: str, prop: Any) -> None:
    """A time with a TZID that neither this machine nor the file's VTIMEZONEs know comes back naive."""
    zone_id = prop.params.get("TZID") if hasattr(prop, "params") else None
    value = prop.dt
    if zone_id and isinstance(value, datetime) and value.tzinfo is None:
        raise CalendarError(
            f"its {name} has the time zone {_short(str(zone_id))}, which neither this machine nor the file "
            "defines; fix: export it again with a known zone (an IANA name such as Europe/Oslo, or with "
            "its VTIMEZONE)"
        )


def _times(vevent: Any, zone: ZoneInfo) -> tuple[datetime, datetime]:
    dtstart = vevent.get("DTSTART")
    if dtstart is None:
        raise CalendarError("it has no DTSTART")
    _check_zone("DTSTART", dtstart)
    if vevent.get("DTEND") is not None:
        _check_zone("DTEND", vevent.get("DTEND"))
    start = _as_aware(dtstart.dt, zone)
    if vevent.get("DTEND") is not None:
        end = _as_aware(vevent.get("DTEND").dt, zone)
    elif vevent.get("DURATION") is not None:
        duration = vevent.get("DURATION").dt
        try:
            end = start + duration
        except OverflowError:
            raise CalendarError(
                f"its DURATION ({duration.days} days) ends after the year 9999; fix: give a real DTEND or DURATION"
            ) from None
    elif not isinstance(dtstart.dt, datetime):
        end = start + timedelta(days=1)
    else:
        raise CalendarError("it has neither DTEND nor DURATION, so it never lasts")
    if end - start > timedelta(days=MAX_EVENT_DAYS):
        raise CalendarError(
            f"it lasts {(end - start).days} days, over the limit of {MAX_EVENT_DAYS}; fix: check its DTEND or "
            "DURATION"
        )
    return start, end


def _place(
    matcher: LocationMatcher, place_text: str, summary: str | None, default_location: str | None
) -> str:
    for text in (place_text, summary or ""):
        match = matcher.find(text) if text else None
        if match is not None:
            return match.location
    if default_location is not None:
        return default_location
    raise CalendarError(
        f"neither LOCATION {place_text!r} nor SUMMARY {summary or ''!r} names a known place "
        f"({', '.join(matcher.names)}); add the place or pass a default location"
    )


def _recurrence(vevent: Any, start: datetime) -> str | None:
    rules = vevent.get("RRULE")
    if rules is None:
        return None
    rules = rules if isinstance(rules, list) else [rules]
    lines = ["RRULE:" + rule.to_ical().decode() for rule in rules[:1]]
    for name in ("EXDATE", "RDATE"):
        lines.extend(_date_line(name, vevent.get(name), start))
    return "\n".join(lines)


def _date_line(name: str, prop: Any, start: datetime) -> list[str]:
    if prop is None:
        return []
    zone = start.tzinfo
    assert isinstance(zone, tzinfo)
    groups: Sequence[Any] = prop if isinstance(prop, list) else [prop]
    stamps = []
    for group in groups:
        for item in group.dts:
            value = item.dt
            if isinstance(value, tuple):  # an RDATE period: its start
                value = value[0]
            if not isinstance(value, datetime):
                value = datetime.combine(value, start.astimezone(zone).time(), zone)
            elif value.tzinfo is None:
                value = value.replace(tzinfo=zone)
            stamps.append(utc_stamp(value))
    return [f"{name}:{','.join(stamps)}"] if stamps else []


def _synthetic_uid(start: datetime, summary: str | None, place: str) -> str:
    """A stable UID for events without one, so importing the same file twice updates them."""
    digest = hashlib.sha1(f"{start.isoformat()}|{summary}|{place}".encode()).hexdigest()[:16]
    return f"cyborg-import-{digest}"


def _short(text: str, limit: int = 120) -> str:
    return repr(text) if len(text) <= limit else repr(text[: limit - 3] + "...")
