"""Issue 12, item 2 and issue 31, item 2: no calendar rule freezes the robot.

Each rule is put in front of a running robot (a whole `cyborg sim --script` in its own
process): rules an older version let into the database (INTERVAL=0 never advances) and rules
that are valid but start long ago (FREQ=SECONDLY since 1990: a billion occurrences before
today), and sparse sub-daily rules, which dateutil walks day by day through the years between
their occurrences (over 10 minutes for one a leap year, on the event loop). The scheduler looks at the calendar every 10 s; the robot must still hear what it is
told a minute later, and `cyborg db events list --at now` must still answer.
"""

from __future__ import annotations

import json
import sqlite3
import time
import urllib.request
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path
from subprocess import CompletedProcess

import pytest

from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.ics import import_ics
from cyborg.navigation.models import CalendarEvent
from tests.hostile.robot import ServedRobot

SCRIPT = """\
start: 2026-11-23T12:00:00
until: 300
steps:
  - at: 60
    say: hello robot
  - at: 90
    event: music_play
"""

ICS = """\
BEGIN:VCALENDAR\r
VERSION:2.0\r
PRODID:-//hostile//EN\r
BEGIN:VEVENT\r
UID:old-and-frequent@example\r
SUMMARY:Cafeteria\r
LOCATION:cafeteria\r
DTSTART:19900101T000000Z\r
DURATION:{duration}\r
RRULE:{rule}\r
END:VEVENT\r
END:VCALENDAR\r
"""

SPARSE = "RRULE:FREQ=SECONDLY;BYMONTH=2;BYMONTHDAY=29;BYHOUR=23;BYMINUTE=59;BYSECOND=59"


def stored_by_an_older_version(db_path: Path, rule: str) -> None:
    """A recurrence written straight into the database, as a version without the checks did."""
    with NavigationDatabase(db_path) as db:
        start = datetime(2020, 1, 1, 8, tzinfo=UTC)
        added = db.add_event(
            CalendarEvent("cafeteria", start, start + timedelta(hours=1), recurrence="FREQ=DAILY")
        )
    with sqlite3.connect(db_path) as conn:
        conn.execute("UPDATE events SET recurrence = ? WHERE id = ?", (rule, added.id))


def imported_from_ics(db_path: Path, rule: str, duration: str) -> None:
    ics = db_path.parent / "old.ics"
    ics.write_text(ICS.format(rule=rule, duration=duration), encoding="utf-8")
    with NavigationDatabase(db_path) as db:
        report = import_ics(db, ics)
    assert len(report.added) == 1, report.skipped


CASES = {
    "stored FREQ=DAILY;INTERVAL=0": lambda db: stored_by_an_older_version(db, "RRULE:FREQ=DAILY;INTERVAL=0"),
    "stored FREQ=SECONDLY;INTERVAL=0": lambda db: stored_by_an_older_version(
        db, "RRULE:FREQ=SECONDLY;INTERVAL=0"
    ),
    ".ics FREQ=SECONDLY since 1990": lambda db: imported_from_ics(db, "FREQ=SECONDLY", "PT1S"),
    ".ics FREQ=MINUTELY since 1990": lambda db: imported_from_ics(db, "FREQ=MINUTELY", "PT30S"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_robot_still_answers_with_the_rule_in_its_calendar(
    case: str, tmp_path: Path, cyborg: Callable[[list[str]], CompletedProcess[str]]
) -> None:
    data = tmp_path / "data"
    data.mkdir()
    CASES[case](data / "navigation.db")
    script = tmp_path / "script.yaml"
    script.write_text(SCRIPT, encoding="utf-8")
    transcript = tmp_path / "t.jsonl"

    run = cyborg(
        [
            "sim",
            "--script",
            str(script),
            "--speed",
            "max",
            "--data-dir",
            str(data),
            "--transcript",
            str(transcript),
        ]
    )

    assert run.returncode == 0, run.stdout + run.stderr
    records = [json.loads(line) for line in transcript.read_text(encoding="utf-8").splitlines()]
    assert {"t": 60.0, "t_ns": 60_000_000_000, "type": "heard", "text": "hello robot"} in records, (
        "the robot heard what it was told"
    )
    assert any(r["type"] == "state" and r["t"] >= 90 for r in records), "the controller still changes state"
    listed = cyborg(["db", "--db", str(data / "navigation.db"), "events", "list", "--at", "now"])
    assert listed.returncode == 0, listed.stdout + listed.stderr
    assert listed.stdout.startswith("id"), listed.stdout


def test_a_robot_with_a_sparse_rule_answers_and_stops_on_sigterm(tmp_path: Path) -> None:
    """Review 2.21: the rule froze the real-time robot from its first scheduler tick and SIGTERM was
    ignored; now its expansion runs out of budget, the rule is skipped with a warning naming it."""
    data = tmp_path / "data"
    data.mkdir()
    stored_by_an_older_version(data / "navigation.db", SPARSE)
    robot = ServedRobot(tmp_path, "--data-dir", str(data))
    try:
        deadline = time.monotonic() + 30
        while "skipping the event" not in robot.text():
            assert time.monotonic() < deadline and robot.process.poll() is None, robot.text()
            time.sleep(0.1)
        for _ in range(3):
            with urllib.request.urlopen(robot.url + "/api/status", timeout=5) as answer:
                assert answer.status == 200
        warning = next(line for line in robot.text().splitlines() if "skipping the event" in line)
        assert "BYMONTHDAY=29" in warning and "fix:" in warning, warning
        assert robot.terminate() == 0, robot.text()
    finally:
        robot.kill()
