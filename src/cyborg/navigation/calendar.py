"""Calendar logic of the navigation module: recurring events and import of .ics files.

Part of the navigation module's pure logic/persistence layer. Scheduled events
("be at the cafeteria every Wednesday 15:00-15:59") are stored with an RFC 5545
recurrence: an RRULE, optionally with EXDATE/RDATE lines. They are expanded with
``dateutil.rrule`` in the event's own time zone (``zoneinfo``), so a weekly event
at 15:00 Europe/Oslo stays at 15:00 local time across daylight-saving changes.
``import_ics`` reads VEVENTs with ``icalendar`` and stores them in the navigation
database, mapping each event's LOCATION (or SUMMARY) to a known place.

No clock is read here: every function takes the time it needs as an argument.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, date, datetime, time, timedelta, tzinfo
from pathlib import Path
from typing import TYPE_CHECKING, Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

import icalendar
from dateutil.rrule import rruleset, rrulestr

from cyborg.errors import DatabaseError
from cyborg.navigation.keywords import LocationMatcher

if TYPE_CHECKING:
    from cyborg.navigation.database import CalendarEvent, NavigationDatabase

DEFAULT_TIMEZONE = "Europe/Oslo"
"""Zone of the Cyborg (Trondheim): used for floating times and all-day events in .ics files."""

RULE_EXAMPLE = "FREQ=WEEKLY;BYDAY=WE or FREQ=DAILY;COUNT=5"
_STAMP = re.compile(r"^(\d{8})(?:T(\d{6})(Z?))?$")


# --- recurrence strings ----------------------------------------------------------------------


def _parse_stamp(value: str, zone: tzinfo, start: datetime, *, end_of_day: bool = False) -> datetime:
    """An iCalendar DATE or DATE-TIME value as an aware datetime (floating values are in ``zone``)."""
    m = _STAMP.match(value.strip())
    if m is None:
        raise ValueError(f"{value!r} is not an iCalendar date (YYYYMMDD) or date-time (YYYYMMDDTHHMMSS[Z])")
    day = datetime.strptime(m.group(1), "%Y%m%d").date()
    if m.group(2) is None:
        clock = time(23, 59, 59) if end_of_day else start.astimezone(zone).time()
        return datetime.combine(day, clock, zone)
    moment = datetime.combine(day, datetime.strptime(m.group(2), "%H%M%S").time())
    return moment.replace(tzinfo=UTC) if m.group(3) else moment.replace(tzinfo=zone)


def _utc_stamp(moment: datetime) -> str:
    return moment.astimezone(UTC).strftime("%Y%m%dT%H%M%SZ")


def _line_zone(params: str, default: tzinfo) -> tzinfo:
    found = re.search(r"TZID=([^;:]+)", params, flags=re.IGNORECASE)
    return ZoneInfo(found.group(1).strip('"')) if found else default


def normalise_recurrence(text: str, start: datetime) -> str:
    """Check a recurrence and return it in stored form: ``RRULE:...`` then EXDATE/RDATE lines in UTC.

    ``text`` is a bare rule (``FREQ=WEEKLY``) or RFC 5545 lines (``RRULE:``, ``EXDATE:``,
    ``RDATE:``, optionally with ``;TZID=``). UNTIL and dates without ``Z`` are read in
    ``start``'s zone and converted to UTC. Raises DatabaseError naming the bad part.
    """
    zone = start.tzinfo
    if zone is None:
        raise DatabaseError(
            f"start {start.isoformat()} has no time zone; give e.g. {start.isoformat()}+01:00"
        )
    lines: list[str] = []
    try:
        for raw in (part.strip() for part in text.strip().splitlines()):
            if not raw:
                continue
            head, sep, value = raw.partition(":")
            if not sep or "=" in head.partition(";")[0]:
                head, value = "RRULE", raw
            name, _, params = head.partition(";")
            name = name.upper()
            if name == "RRULE":
                lines.append("RRULE:" + _normalise_rule(value, zone, start))
            elif name in ("EXDATE", "RDATE"):
                line_zone = _line_zone(params, zone)
                stamps = [_utc_stamp(_parse_stamp(v, line_zone, start)) for v in value.split(",")]
                lines.append(f"{name}:{','.join(stamps)}")
            else:
                raise ValueError(f"unsupported line {raw!r}; use RRULE, EXDATE or RDATE")
        if not any(line.startswith("RRULE:") for line in lines):
            raise ValueError("it has no RRULE")
        build_rule_set("\n".join(lines), start)
    except (ValueError, KeyError, ZoneInfoNotFoundError) as exc:
        raise DatabaseError(
            f"recurrence {text!r} is not valid ({exc}); write a rule like {RULE_EXAMPLE}"
        ) from exc
    return "\n".join(lines)


def _normalise_rule(value: str, zone: tzinfo, start: datetime) -> str:
    parts = []
    for part in value.strip().split(";"):
        key, sep, val = part.partition("=")
        if not sep:
            raise ValueError(f"rule part {part!r} is not KEY=VALUE")
        key = key.strip().upper()
        if key == "UNTIL":
            val = _utc_stamp(_parse_stamp(val, zone, start, end_of_day=True))
        parts.append(f"{key}={val.strip().upper()}")
    return ";".join(parts)


def build_rule_set(recurrence: str, start: datetime) -> rruleset:
    """The dateutil rule set of a stored recurrence; ``start`` is always the first occurrence."""
    rules = rrulestr(recurrence, dtstart=start, forceset=True)
    assert isinstance(rules, rruleset)
    rules.rdate(start)
    return rules


# --- occurrences -----------------------------------------------------------------------------


def occurrences_between(
    start: datetime,
    end: datetime,
    recurrence: str | None,
    window_start: datetime,
    window_end: datetime,
) -> list[tuple[datetime, datetime]]:
    """Occurrences (start, end) of an event that overlap ``[window_start, window_end)``, in order.

    Occurrences keep the wall-clock time and length of the first one in its own zone.
    """
    length = end - start
    if recurrence is None:
        starts = [start]
    else:
        rules = build_rule_set(recurrence, start)
        starts = rules.between(window_start - length - timedelta(seconds=1), window_end, inc=True)
    found = []
    for occ in starts:
        occ_end = occ + length
        if occ < window_end and occ_end > window_start:
            found.append((occ, occ_end))
    return found


def ongoing_occurrence(
    start: datetime, end: datetime, recurrence: str | None, now: datetime
) -> tuple[datetime, datetime] | None:
    """The occurrence with ``occ_start <= now < occ_end``, or None (the latest if several overlap)."""
    if now.tzinfo is None:
        raise ValueError(
            f"now={now.isoformat()} is naive; pass an aware time, e.g. datetime.now(timezone.utc)"
        )
    hits = [
        (s, e)
        for s, e in occurrences_between(start, end, recurrence, now, now + timedelta(microseconds=1))
        if s <= now < e
    ]
    return hits[-1] if hits else None


# --- .ics import -----------------------------------------------------------------------------


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
    db: NavigationDatabase,
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
    from cyborg.navigation.database import CalendarEvent  # the database imports this module

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
            event = _convert(vevent, matcher, default_location, zone, CalendarEvent)
            event = db.validate_event(event)
            assert event.uid is not None
            if event.uid in pending:
                raise ValueError(f"UID {event.uid!r} appears twice in the file; the first one was imported")
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
        data = path.read_bytes()
    except OSError as exc:
        raise DatabaseError(f"cannot read {path}: {exc}; check the file name") from exc
    try:
        return icalendar.Calendar.from_ical(data)
    except ValueError as exc:
        raise DatabaseError(
            f"{path} is not an iCalendar file ({exc}); export the calendar again as .ics"
        ) from exc


def _convert(
    vevent: Any,
    matcher: LocationMatcher,
    default_location: str | None,
    zone: ZoneInfo,
    make: type[CalendarEvent],
) -> CalendarEvent:
    """One VEVENT as an (unchecked) CalendarEvent; ValueError says why it cannot be imported."""
    if vevent.get("RECURRENCE-ID") is not None:
        raise ValueError("it changes one occurrence of a recurring event, which is not supported")
    if str(vevent.get("STATUS", "")).upper() == "CANCELLED":
        raise ValueError("it is cancelled")
    start, end = _times(vevent, zone)
    summary = str(vevent.get("SUMMARY", "")).strip() or None
    place_text = str(vevent.get("LOCATION", "")).strip()
    location = _place(matcher, place_text, summary, default_location)
    recurrence = _recurrence(vevent, start)
    uid = str(vevent.get("UID", "")).strip() or _synthetic_uid(start, summary, place_text)
    return make(location, start, end, recurrence=recurrence, summary=summary, uid=uid)


def _as_aware(value: date | datetime, zone: ZoneInfo) -> datetime:
    if not isinstance(value, datetime):
        return datetime.combine(value, time(0), zone)
    if value.tzinfo is None:
        return value.replace(tzinfo=zone)
    if isinstance(value.tzinfo, ZoneInfo) or value.utcoffset() == timedelta(0):
        return value
    # A custom VTIMEZONE: the Cyborg's own zone keeps recurrences on local time.
    return value.astimezone(zone)


def _times(vevent: Any, zone: ZoneInfo) -> tuple[datetime, datetime]:
    dtstart = vevent.get("DTSTART")
    if dtstart is None:
        raise ValueError("it has no DTSTART")
    start = _as_aware(dtstart.dt, zone)
    if vevent.get("DTEND") is not None:
        end = _as_aware(vevent.get("DTEND").dt, zone)
    elif vevent.get("DURATION") is not None:
        end = start + vevent.get("DURATION").dt
    elif not isinstance(dtstart.dt, datetime):
        end = start + timedelta(days=1)
    else:
        raise ValueError("it has neither DTEND nor DURATION, so it never lasts")
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
    raise ValueError(
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
            stamps.append(_utc_stamp(value))
    return [f"{name}:{','.join(stamps)}"] if stamps else []


def _synthetic_uid(start: datetime, summary: str | None, place: str) -> str:
    """A stable UID for events without one, so importing the same file twice updates them."""
    digest = hashlib.sha1(f"{start.isoformat()}|{summary}|{place}".encode()).hexdigest()[:16]
    return f"cyborg-import-{digest}"
