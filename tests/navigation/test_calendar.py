"""Recurring calendar events (across daylight-saving changes) and .ics import."""

from __future__ import annotations

import sqlite3
from datetime import UTC, datetime, timedelta
from pathlib import Path
from zoneinfo import ZoneInfo

import icalendar
import pytest
import recurring_ical_events

from cyborg.errors import DatabaseError
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.ics import import_ics
from cyborg.navigation.models import CalendarEvent
from cyborg.navigation.recurrence import (
    build_rule_set,
    normalise_recurrence,
    occurrences_between,
    ongoing_occurrence,
)

OSLO = ZoneInfo("Europe/Oslo")


def at(year: int, month: int, day: int, hour: int = 0, minute: int = 0) -> datetime:
    return datetime(year, month, day, hour, minute, tzinfo=OSLO)


def utc(year: int, month: int, day: int, hour: int = 0, minute: int = 0) -> datetime:
    return datetime(year, month, day, hour, minute, tzinfo=UTC)


@pytest.fixture
def db(tmp_path: Path) -> NavigationDatabase:
    return NavigationDatabase(tmp_path / "nav.db")


# --- recurrence and daylight saving ------------------------------------------------------------

# 2024: summer time starts Sunday 31 March, ends Sunday 27 October (Europe/Oslo).


def test_weekly_event_stays_at_15_local_across_spring_change() -> None:
    start, end = at(2024, 3, 28, 15), at(2024, 3, 28, 15, 59)  # Thursday, winter time (UTC+1)
    rule = normalise_recurrence("FREQ=WEEKLY", start)
    found = occurrences_between(start, end, rule, at(2024, 3, 27), at(2024, 4, 12))
    assert [s.astimezone(OSLO).strftime("%m-%d %H:%M") for s, _ in found] == [
        "03-28 15:00",
        "04-04 15:00",
        "04-11 15:00",
    ]
    assert [s.astimezone(UTC).hour for s, _ in found] == [14, 13, 13]
    # 15:30 local after the change is 13:30 UTC: ongoing. 16:30 local (14:30 UTC) is not.
    assert ongoing_occurrence(start, end, rule, utc(2024, 4, 4, 13, 30)) == (
        at(2024, 4, 4, 15),
        at(2024, 4, 4, 15, 59),
    )
    assert ongoing_occurrence(start, end, rule, utc(2024, 4, 4, 14, 30)) is None


def test_weekly_event_on_the_autumn_change_day_stays_at_15_local(db: NavigationDatabase) -> None:
    start = at(2024, 10, 20, 15)  # a Sunday in summer time (UTC+2); 27 October is the change day
    db.add_event(CalendarEvent("cafeteria", start, start + timedelta(minutes=59), recurrence="FREQ=WEEKLY"))
    assert db.ongoing_events(utc(2024, 10, 27, 14, 30))  # 15:30 local, winter time
    assert not db.ongoing_events(utc(2024, 10, 27, 13, 30))  # 14:30 local: not yet
    assert db.ongoing_events(at(2024, 10, 27, 15, 58))
    assert not db.ongoing_events(at(2024, 10, 27, 15, 59))


def test_expansion_agrees_with_recurring_ical_events() -> None:
    """Cross-check against an independent library on the same rule, over both changes."""
    start, end = at(2024, 3, 1, 15), at(2024, 3, 1, 16)
    text = "FREQ=WEEKLY;BYDAY=FR,SU;UNTIL=20241201T000000Z"
    ours = occurrences_between(start, end, normalise_recurrence(text, start), at(2024, 1, 1), at(2025, 1, 1))
    cal = icalendar.Calendar()
    vevent = icalendar.Event()
    vevent.add("uid", "x")
    vevent.add("dtstart", start)
    vevent.add("dtend", end)
    vevent.add("rrule", icalendar.vRecur.from_ical(text))
    cal.add_component(vevent)
    theirs = recurring_ical_events.of(cal).between(at(2024, 1, 1), at(2025, 1, 1))
    assert len(ours) > 60
    assert [s for s, _ in ours] == sorted(e["DTSTART"].dt for e in theirs)


def test_count_until_and_exdate_limit_occurrences() -> None:
    start, end = at(2024, 5, 6, 10), at(2024, 5, 6, 11)
    window = (at(2024, 5, 1), at(2024, 6, 30))

    def days(rule: str) -> list[int]:
        return [s.day for s, _ in occurrences_between(start, end, normalise_recurrence(rule, start), *window)]

    assert days("FREQ=DAILY;COUNT=3") == [6, 7, 8]
    assert days("FREQ=DAILY;UNTIL=20240508") == [6, 7, 8]  # a date UNTIL includes that whole local day
    assert days("RRULE:FREQ=DAILY;COUNT=3\nEXDATE;TZID=Europe/Oslo:20240507T100000") == [6, 8]


def test_non_recurring_event_has_one_occurrence() -> None:
    start, end = at(2024, 5, 6, 10), at(2024, 5, 6, 11)
    assert occurrences_between(start, end, None, at(2024, 5, 1), at(2024, 6, 1)) == [(start, end)]
    assert occurrences_between(start, end, None, at(2024, 5, 7), at(2024, 6, 1)) == []


def test_occurrence_started_before_the_window_overlaps_it() -> None:
    start, end = at(2024, 5, 6, 22), at(2024, 5, 7, 2)  # spans midnight
    rule = normalise_recurrence("FREQ=DAILY", start)
    found = occurrences_between(start, end, rule, at(2024, 5, 9, 0), at(2024, 5, 9, 1))
    assert found == [(at(2024, 5, 8, 22), at(2024, 5, 9, 2))]


def test_normalised_form_is_stored_in_utc_and_stable() -> None:
    start = at(2024, 5, 6, 10)
    text = normalise_recurrence("freq=weekly;until=20240601", start)
    assert text == "RRULE:FREQ=WEEKLY;UNTIL=20240601T215959Z"
    assert normalise_recurrence(text, start) == text


@pytest.mark.parametrize(
    ("rule", "message"),
    [
        ("FREQ=SOMETIMES", "SOMETIMES"),
        ("weekly", "not KEY=VALUE"),
        ("EXDATE:20240101T100000Z", "has no RRULE"),
        ("FOO:BAR", "unsupported line"),
        ("FREQ=DAILY;UNTIL=tomorrow", "tomorrow"),
    ],
)
def test_bad_rules_name_the_problem_and_an_example(rule: str, message: str) -> None:
    with pytest.raises(DatabaseError, match=message) as info:
        normalise_recurrence(rule, at(2024, 1, 1, 9))
    assert "FREQ=WEEKLY" in str(info.value)


def test_naive_times_are_refused() -> None:
    with pytest.raises(DatabaseError, match="no time zone"):
        normalise_recurrence("FREQ=DAILY", datetime(2024, 1, 1, 9))
    with pytest.raises(ValueError, match="naive"):
        ongoing_occurrence(at(2024, 1, 1, 9), at(2024, 1, 1, 10), None, datetime(2024, 1, 1, 9))


# --- .ics import -----------------------------------------------------------------------------

ICS = """BEGIN:VCALENDAR
VERSION:2.0
PRODID:-//cyborg tests//EN
BEGIN:VEVENT
UID:coffee@ntnu
SUMMARY:Coffee break
LOCATION:Cafetria\\, Glassgården
DTSTART;TZID=Europe/Oslo:20240321T150000
DTEND;TZID=Europe/Oslo:20240321T155900
RRULE:FREQ=WEEKLY;UNTIL=20240501T000000Z
EXDATE;TZID=Europe/Oslo:20240411T150000
END:VEVENT
BEGIN:VEVENT
UID:lecture@ntnu
SUMMARY:Lecture in EL 6
DTSTART:20240322T081500Z
DURATION:PT1H30M
END:VEVENT
BEGIN:VEVENT
SUMMARY:Open day
LOCATION:waiting area
DTSTART;VALUE=DATE:20240323
END:VEVENT
BEGIN:VEVENT
UID:gym@ntnu
SUMMARY:Training
LOCATION:Gym
DTSTART:20240322T170000Z
DTEND:20240322T180000Z
END:VEVENT
BEGIN:VEVENT
UID:cancelled@ntnu
SUMMARY:Cancelled visit
LOCATION:el5
STATUS:CANCELLED
DTSTART:20240322T170000Z
DTEND:20240322T180000Z
END:VEVENT
BEGIN:VEVENT
UID:endless@ntnu
SUMMARY:No end
LOCATION:el5
DTSTART:20240322T170000Z
END:VEVENT
END:VCALENDAR
"""


def write_ics(tmp_path: Path, text: str = ICS) -> Path:
    path = tmp_path / "calendar.ics"
    path.write_text(text.replace("\n", "\r\n"), encoding="utf-8")
    return path


def test_import_maps_places_and_reports_skips(db: NavigationDatabase, tmp_path: Path) -> None:
    report = import_ics(db, write_ics(tmp_path))
    assert sorted((e.summary, e.location) for e in report.added) == [
        ("Coffee break", "cafeteria"),
        ("Lecture in EL 6", "el6"),
        ("Open day", "waiting area"),
    ]
    reasons = {s.summary: s.reason for s in report.skipped}
    assert set(reasons) == {"Training", "Cancelled visit", "No end"}
    assert "'Gym'" in reasons["Training"] and "known place" in reasons["Training"]
    assert "cancelled" in reasons["Cancelled visit"]
    assert "DTEND" in reasons["No end"]
    assert len(db.list_events()) == 3


def test_imported_rrule_exdate_and_duration_drive_ongoing(db: NavigationDatabase, tmp_path: Path) -> None:
    import_ics(db, write_ics(tmp_path))

    def where(now: datetime) -> list[str]:
        return [o.event.location for o in db.ongoing_events(now)]

    assert where(at(2024, 3, 28, 15, 30)) == ["cafeteria"]  # winter time
    assert where(at(2024, 4, 4, 15, 30)) == ["cafeteria"]  # summer time, still 15:00 local
    assert where(at(2024, 4, 4, 16, 30)) == []
    assert where(at(2024, 4, 11, 15, 30)) == []  # EXDATE
    assert where(at(2024, 5, 2, 15, 30)) == []  # after UNTIL
    assert where(utc(2024, 3, 22, 9, 40)) == ["el6"]  # 08:15 + 1h30 UTC
    assert where(utc(2024, 3, 22, 9, 45)) == []
    assert where(at(2024, 3, 23, 23, 59)) == ["waiting area"]  # all day, local
    assert where(at(2024, 3, 24, 0, 0)) == []


def test_reimport_updates_instead_of_duplicating(db: NavigationDatabase, tmp_path: Path) -> None:
    import_ics(db, write_ics(tmp_path))
    coffee = next(e for e in db.list_events() if e.uid == "coffee@ntnu")
    db.update_event(coffee.id or 0, CalendarEvent(**{**coffee.__dict__, "ignored": True}))
    moved = ICS.replace("Cafetria\\, Glassgården", "EL5")
    report = import_ics(db, write_ics(tmp_path, moved))
    assert (len(report.added), len(report.updated)) == (0, 3)
    assert len(db.list_events()) == 3
    coffee = next(e for e in db.list_events() if e.uid == "coffee@ntnu")
    assert coffee.location == "el5"
    assert coffee.ignored  # the user's choice survives a re-import


def test_default_location_catches_unknown_places(db: NavigationDatabase, tmp_path: Path) -> None:
    report = import_ics(db, write_ics(tmp_path), default_location="Info")
    training = next(e for e in report.added if e.summary == "Training")
    assert training.location == "information desk"
    with pytest.raises(DatabaseError, match="unknown location 'nowhere'"):
        import_ics(db, write_ics(tmp_path), default_location="nowhere")


def test_floating_times_are_read_in_the_given_zone(db: NavigationDatabase, tmp_path: Path) -> None:
    text = ICS.replace("DTSTART;TZID=Europe/Oslo:20240321T150000", "DTSTART:20240321T150000")
    text = text.replace("DTEND;TZID=Europe/Oslo:20240321T155900", "DTEND:20240321T155900")
    import_ics(db, write_ics(tmp_path, text), local_tz="America/New_York")
    coffee = next(e for e in db.list_events() if e.uid == "coffee@ntnu")
    assert coffee.start == datetime(2024, 3, 21, 15, tzinfo=ZoneInfo("America/New_York"))


def test_bad_files_raise_with_a_fix(db: NavigationDatabase, tmp_path: Path) -> None:
    with pytest.raises(DatabaseError, match="cannot read"):
        import_ics(db, tmp_path / "missing.ics")
    bad = tmp_path / "bad.ics"
    bad.write_text("this is not a calendar")
    with pytest.raises(DatabaseError, match=r"not an iCalendar file.*export"):
        import_ics(db, bad)
    with pytest.raises(DatabaseError, match="unknown time zone 'Mars/Base'"):
        import_ics(db, write_ics(tmp_path), local_tz="Mars/Base")
    assert db.list_events() == []


def test_events_without_uid_get_a_stable_one(db: NavigationDatabase, tmp_path: Path) -> None:
    first = import_ics(db, write_ics(tmp_path))
    second = import_ics(db, write_ics(tmp_path))
    [open_day] = [e for e in first.added if e.summary == "Open day"]
    assert open_day.uid and open_day.uid.startswith("cyborg-import-")
    assert open_day.uid in {e.uid for e in second.updated}


# --- rules that would never finish expanding (issue 12, item 2) --------------------------------


@pytest.mark.parametrize(
    ("rule", "length", "message"),
    [
        ("FREQ=DAILY;INTERVAL=0", timedelta(hours=1), "INTERVAL=0 must be a whole number of at least 1"),
        ("FREQ=SECONDLY;INTERVAL=-2", timedelta(seconds=1), "INTERVAL=-2 must be a whole number"),
        ("FREQ=WEEKLY;COUNT=-1", timedelta(hours=1), "COUNT=-1 must be a whole number from 1 to 10000"),
        ("FREQ=DAILY;COUNT=10001", timedelta(hours=1), "COUNT=10001 must be a whole number from 1 to 10000"),
        ("FREQ=DAILY;COUNT=3;UNTIL=20240601", timedelta(hours=1), "both COUNT and UNTIL"),
        ("FREQ=MINUTELY;BYSETPOS=2", timedelta(seconds=1), "BYSETPOS with FREQ=MINUTELY"),
        ("FREQ=DAILY;BYMONTH=2;BYMONTHDAY=30", timedelta(hours=1), "never repeats"),
        ("FREQ=SECONDLY", timedelta(hours=1), "its occurrences overlap"),
        ("FREQ=YEARLY", timedelta(days=400), "over the limit of 366 days"),
    ],
)
def test_rules_that_repeat_nothing_or_never_stop_expanding_are_refused_with_the_fix(
    rule: str, length: timedelta, message: str
) -> None:
    start = at(2024, 1, 1, 9)
    with pytest.raises(DatabaseError, match=message) as info:
        normalise_recurrence(rule, start, start + length)
    assert "fix:" in str(info.value)


def test_events_add_refuses_interval_0_and_stores_nothing(db: NavigationDatabase) -> None:
    start = at(2024, 1, 1, 9)
    event = CalendarEvent("cafeteria", start, start + timedelta(hours=1), recurrence="FREQ=DAILY;INTERVAL=0")
    with pytest.raises(DatabaseError, match="INTERVAL=0"):
        db.add_event(event)
    assert db.list_events() == []


@pytest.mark.parametrize(
    "rule",
    [
        "FREQ=SECONDLY;INTERVAL=7",
        "FREQ=MINUTELY;INTERVAL=13;BYHOUR=8,9,10",
        "FREQ=HOURLY;INTERVAL=5;BYMINUTE=0,30",
        "FREQ=DAILY;INTERVAL=3;BYHOUR=9,15",
        "FREQ=WEEKLY;INTERVAL=2;BYDAY=MO,FR;WKST=SU",
        "FREQ=MONTHLY;BYMONTHDAY=31",
        "FREQ=MONTHLY;INTERVAL=5;BYDAY=-1FR",
        "FREQ=YEARLY;BYMONTH=2;BYMONTHDAY=29",
        "FREQ=DAILY;COUNT=2000\nEXDATE:20240105T080000Z",
    ],
)
def test_a_window_years_after_the_start_sees_the_same_occurrences_as_expanding_from_the_start(
    rule: str,
) -> None:
    # The windowed expansion starts the rule a whole number of periods before the window; dateutil
    # expanding from the first start is the reference.
    # (The reference is slow for rules repeating within the hour: they start a few days before.)
    often = "SECONDLY" in rule or "MINUTELY" in rule
    start = at(2019, 3, 29, 9) if often else at(2019, 1, 31, 9)
    end = start + (timedelta(seconds=1) if "SECONDLY" in rule else timedelta(minutes=1))
    stored = normalise_recurrence(rule, start, end)
    length = end - start
    windows = [at(2019, 3, 31, 1), at(2019, 4, 2, 7)]
    windows += [] if often else [at(2024, 3, 31, 1), at(2024, 10, 27, 2), at(2028, 2, 28)]
    for window_start in windows:
        window_end = window_start + timedelta(hours=20)
        reference = build_rule_set(stored, start).between(window_start - length, window_end, inc=True)
        expected = [(s, s + length) for s in reference if s + length > window_start and s < window_end]
        assert occurrences_between(start, end, stored, window_start, window_end) == expected[:1000], rule


def test_a_rule_an_older_version_stored_is_skipped_with_a_warning(
    db: NavigationDatabase, caplog: pytest.LogCaptureFixture
) -> None:
    start = at(2024, 1, 1, 9)
    good = db.add_event(
        CalendarEvent("cafeteria", start, start + timedelta(hours=1), recurrence="FREQ=DAILY")
    )
    bad = db.add_event(CalendarEvent("el5", start, start + timedelta(hours=1), recurrence="FREQ=DAILY"))
    with sqlite3.connect(db.path) as conn:  # as written before the checks existed
        conn.execute("UPDATE events SET recurrence = 'RRULE:FREQ=DAILY;COUNT=-1' WHERE id = ?", (bad.id,))
    ongoing = db.ongoing_events(at(2024, 5, 6, 9, 30))
    assert [o.event.id for o in ongoing] == [good.id]
    assert any("COUNT=-1" in r.getMessage() and "skipping" in r.getMessage() for r in caplog.records)
