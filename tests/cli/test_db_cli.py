"""The ``db`` command group: tables out, data in, clear errors with exit code 2."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo

import pytest
from click.testing import CliRunner, Result

from cyborg.cli import db as db_cli
from cyborg.cli.db import db_group
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.models import ResponseType
from tests.support.paths import GLASSGARDEN


@pytest.fixture
def db_path(tmp_path: Path) -> Path:
    return tmp_path / "nav.db"


def run(db_path: Path, *args: str) -> Result:
    return CliRunner().invoke(db_group, ["--db", str(db_path), *args])


def snapshot(db_path: Path) -> tuple[Any, ...]:
    with NavigationDatabase(db_path) as db:
        return (db.list_locations(), db.list_events(), db.list_responses())


def test_locations_list_shows_the_defaults_as_a_table(db_path: Path) -> None:
    result = run(db_path, "locations", "list")
    assert result.exit_code == 0, result.output
    header, rule, *rows = result.output.splitlines()[:10]
    assert header.split()[:3] == ["name", "aliases", "map"]
    assert set(rule) <= {"-", " "}
    assert any(row.startswith("el6") and "e16" in row for row in rows)
    assert len(rows) == 8


def test_locations_shows_which_places_have_no_pose_and_how_to_give_one(db_path: Path) -> None:
    """Issue 11.6: `cyborg db locations` on a fresh database, then one place given a pose."""
    result = run(db_path, "locations")
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    cafe = next(line.split() for line in lines if line.startswith("cafeteria"))
    assert cafe[:6] == ["cafeteria", "canteen", "-", "-", "-", "-"]  # map, x, y, heading: none
    assert "no pose: cafeteria, el5, el6, elevator, entrance, entrance 2, information desk, waiting area" in (
        result.output
    )
    assert "cyborg db import-map MAP" in result.output
    assert "cyborg db locations set-pose NAME --x X --y Y" in result.output

    placed = run(db_path, "locations", "set-pose", "canteen", "--x", "12", "--y", "3.5")
    assert placed.exit_code == 0, placed.output
    assert placed.output == "location 'cafeteria' is at (12.00, 3.50)\n"
    listed = run(db_path, "locations", "list").output
    cafe = next(line.split() for line in listed.splitlines() if line.startswith("cafeteria"))
    assert cafe[:6] == ["cafeteria", "canteen", "-", "12.00", "3.50", "0.00"]
    assert "no pose: el5, el6, elevator" in listed
    with NavigationDatabase(db_path) as db:
        assert db.is_target(db.get_location("cafeteria"))


def test_set_pose_uses_the_map_in_use_and_refuses_unknown_places(db_path: Path) -> None:
    with NavigationDatabase(db_path) as db:
        db.use_map("campus")
    result = run(db_path, "locations", "set-pose", "el5", "--x", "30", "--y", "43.5", "--heading", "1.57")
    assert result.output == "location 'el5' is at (30.00, 43.50) on map 'campus'\n"
    with NavigationDatabase(db_path) as db:
        el5 = db.get_location("el5")
        assert (el5.map, el5.position, el5.heading) == ("campus", (30.0, 43.5), 1.57) and db.is_target(el5)
    missing = run(db_path, "locations", "set-pose", "gym", "--x", "1", "--y", "2")
    assert missing.exit_code == 2 and "unknown location 'gym'" in missing.output
    assert run(db_path, "locations", "set-pose", "el6", "--x", "1").exit_code == 2  # --y is required


def test_a_location_added_without_coordinates_has_no_pose(db_path: Path) -> None:
    result = run(db_path, "locations", "add", "library")
    assert result.output == "added location 'library', no pose yet\n"
    with NavigationDatabase(db_path) as db:
        assert db.get_location("library").position is None
    assert "library" in run(db_path, "locations").output.splitlines()[-2]  # in the "no pose" line


def test_locations_add_and_remove(db_path: Path) -> None:
    result = run(
        db_path, "locations", "add", "gym", "--alias", "hall", "--x", "1.5", "--y", "-2", "--crowded"
    )
    assert result.exit_code == 0, result.output
    with NavigationDatabase(db_path) as db:
        gym = db.get_location("hall")
    assert (gym.name, gym.x, gym.y, gym.crowded) == ("gym", 1.5, -2.0, True)
    assert "gym" in run(db_path, "locations", "list").output
    assert run(db_path, "locations", "remove", "HALL").exit_code == 0
    with NavigationDatabase(db_path) as db:
        assert db.find_location("gym") is None


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("locations", "add", "Cafeteria"), "'Cafeteria' is already used by location 'cafeteria'"),
        (("locations", "add", "gym", "--pleasantness", "2"), "pleasantness=2.0 of 'gym' is outside -1..1"),
        (("locations", "add", "gym", "--x", "1"), "'gym' has x but no y; give both"),
        (("locations", "add", "gym", "--map", "campus"), "'gym' is on map 'campus' but has no x and y"),
        (("locations", "remove", "gym"), "unknown location 'gym'"),
        (("events", "add", "gym", "2024-03-20T15:00", "2024-03-20T16:00"), "unknown location 'gym'"),
        (("events", "add", "el5", "2024-03-20T16:00", "2024-03-20T15:00"), "is not after start"),
        (
            ("events", "add", "el5", "20 March", "2024-03-20T15:00"),
            "START '20 March' is not an ISO 8601 time",
        ),
        (("events", "add", "el5", "2024-03-20T15:00", "2024-03-20T16:00", "--rrule", "x=1"), "is not valid"),
        (
            ("events", "add", "el5", "2024-03-20T15:00", "2024-03-20T16:00", "--tz", "Oslo"),
            "unknown time zone",
        ),
        (("events", "remove", "99"), "no calendar event with id 99"),
        (("responses", "add", "opinion", "I like it"), "lacks the placeholder LOCATION"),
        (("responses", "remove", "9999"), "no response with id 9999"),
    ],
)
def test_bad_input_exits_2_naming_the_value_and_writes_nothing(
    db_path: Path, args: tuple[str, ...], message: str
) -> None:
    before = snapshot(db_path)
    result = run(db_path, *args)
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert snapshot(db_path) == before


def test_unknown_response_type_is_a_usage_error(db_path: Path) -> None:
    result = run(db_path, "responses", "add", "gossip", "LOCATION!")
    assert result.exit_code == 2
    assert "gossip" in result.output and "opinion" in result.output


def test_events_add_list_remove(db_path: Path) -> None:
    result = run(
        db_path, "events", "add", "cafetEria", "2024-03-28T15:00", "2024-03-28T15:59",
        "--rrule", "FREQ=WEEKLY", "--summary", "coffee",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    with NavigationDatabase(db_path) as db:
        [event] = db.list_events()
    assert event.location == "cafeteria" and event.start.utcoffset() is not None
    assert event.start.astimezone(ZoneInfo("Europe/Oslo")).hour == 15
    listed = run(db_path, "events", "list").output
    assert "cafeteria" in listed and "FREQ=WEEKLY" in listed and "coffee" in listed
    # after the change to summer time it is still 15:00 local
    assert "cafeteria" in run(db_path, "events", "list", "--at", "2024-04-04T15:30").output
    assert "cafeteria" not in run(db_path, "events", "list", "--at", "2024-04-04T16:30").output
    assert run(db_path, "events", "remove", str(event.id)).exit_code == 0
    with NavigationDatabase(db_path) as db:
        assert db.list_events() == []


def test_responses_add_list_remove(db_path: Path) -> None:
    result = run(db_path, "responses", "add", "opinion", "The LOCATION glows.", "--emotion", "elated")
    assert result.exit_code == 0, result.output
    listed = run(db_path, "responses", "list", "--type", "opinion", "--emotion", "elated").output
    assert "The LOCATION glows." in listed
    with NavigationDatabase(db_path) as db:
        [added] = [r for r in db.list_responses(ResponseType.OPINION) if r.sentence == "The LOCATION glows."]
    assert run(db_path, "responses", "remove", str(added.id)).exit_code == 0
    assert "glows" not in run(db_path, "responses", "list").output


def test_import_ics_reports_and_stores(db_path: Path, tmp_path: Path) -> None:
    ics = tmp_path / "c.ics"
    ics.write_text(
        "BEGIN:VCALENDAR\r\nVERSION:2.0\r\nPRODID:-//t//EN\r\n"
        "BEGIN:VEVENT\r\nUID:a\r\nSUMMARY:Lunch\r\nLOCATION:canteen\r\n"
        "DTSTART;TZID=Europe/Oslo:20240320T113000\r\nDTEND;TZID=Europe/Oslo:20240320T120000\r\n"
        "RRULE:FREQ=DAILY;COUNT=5\r\nEND:VEVENT\r\n"
        "BEGIN:VEVENT\r\nUID:b\r\nSUMMARY:Swim\r\nLOCATION:pool\r\n"
        "DTSTART:20240320T170000Z\r\nDTEND:20240320T180000Z\r\nEND:VEVENT\r\n"
        "END:VCALENDAR\r\n"
    )
    result = run(db_path, "import-ics", str(ics))
    assert result.exit_code == 0, result.output
    assert "added 1, updated 0, skipped 1" in result.output
    assert "skipped 'Swim'" in result.output and "'pool'" in result.output
    assert run(db_path, "import-ics", str(ics)).output.startswith("added 0, updated 1")
    with NavigationDatabase(db_path) as db:
        assert [e.location for e in db.list_events()] == ["cafeteria"]


def test_import_ics_of_a_missing_file_exits_2(db_path: Path, tmp_path: Path) -> None:
    result = run(db_path, "import-ics", str(tmp_path / "nope.ics"))
    assert result.exit_code == 2 and "nope.ics" in result.output


@dataclass(frozen=True)
class FakePose:
    name: str
    x: float
    y: float
    theta: float


@dataclass(frozen=True)
class FakeMap:
    named_poses: tuple[FakePose, ...]


def test_import_map_adds_new_places_and_moves_known_ones(
    db_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    map_file = tmp_path / "glassgarden.map"
    map_file.write_text("not read by the fake loader")
    poses = (
        FakePose("Cafeteria", 12.0, 3.5, 1.57),
        FakePose("e16", -4.0, 8.0, 0.0),
        FakePose("printer", 1.0, 1.0, 3.0),
        FakePose("bad", float("nan"), 0.0, 0.0),
    )
    seen: list[Path] = []

    def loader(path: Path) -> FakeMap:
        seen.append(path)
        return FakeMap(poses)

    monkeypatch.setattr(db_cli, "_map_loader", lambda: loader)
    result = run(db_path, "import-map", str(map_file))
    assert result.exit_code == 0, result.output
    assert seen == [map_file]
    assert "skipped 'bad'" in result.output
    with NavigationDatabase(db_path) as db:
        cafe, el6, printer = db.get_location("cafeteria"), db.get_location("el6"), db.get_location("printer")
        assert db.find_location("bad") is None
    assert (cafe.x, cafe.y, cafe.heading, cafe.map) == (12.0, 3.5, 1.57, "glassgarden")
    assert cafe.crowded and cafe.aliases == ("canteen",)  # the rest is kept
    assert (el6.x, el6.y) == (-4.0, 8.0)
    assert (printer.x, printer.heading) == (1.0, 3.0)


def test_import_map_without_the_map_module_exits_2(
    db_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    map_file = tmp_path / "x.map"
    map_file.write_text("")
    monkeypatch.setitem(sys.modules, "cyborg.maps", None)  # makes the import fail
    result = run(db_path, "import-map", str(map_file))
    assert result.exit_code == 2
    assert "cyborg.maps is not available" in result.output


def test_default_path_follows_cyborg_data_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CYBORG_DATA_DIR", str(tmp_path / "data"))
    result = CliRunner().invoke(db_group, ["locations", "list"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "data" / "navigation.db").exists()
    monkeypatch.delenv("CYBORG_DATA_DIR")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert db_cli.default_db_path() == tmp_path / "home" / ".local" / "share" / "cyborg" / "navigation.db"


def test_import_map_reads_goals_of_a_real_arnl_map(db_path: Path, tmp_path: Path) -> None:
    map_file = tmp_path / "hall.map"
    map_file.write_text(
        "2D-Map\nMinPos: 0 0\nMaxPos: 10000 5000\n"
        'Cairn: GoalWithHeading 8000 2000 90 "" ICON "cafeteria"\n'
        'Cairn: GoalWithHeading 1000 1500 0 "" ICON "printer room"\n'
        "LINES\n0 0 10000 0\n0 5000 10000 5000\nDATA\n100 100\n9000 4000\n"
    )
    result = run(db_path, "import-map", str(map_file), "--map-name", "glassgarden")
    assert result.exit_code == 0, result.output
    with NavigationDatabase(db_path) as db:
        cafe, printer = db.get_location("cafeteria"), db.get_location("printer room")
    assert (cafe.x, cafe.y, cafe.map) == (8.0, 2.0, "glassgarden")
    assert cafe.heading == pytest.approx(1.5708, abs=1e-3)
    assert (printer.x, printer.y) == (1.0, 1.5)


def test_import_map_of_glassgarden_places_the_default_places_at_its_goals(db_path: Path) -> None:
    glassgarden = GLASSGARDEN
    result = run(db_path, "import-map", str(glassgarden))
    assert result.exit_code == 0, result.output
    assert "updated 'waiting area' (the map's 'waitingarea') to (-33.58, 10.63)" in result.output
    assert "updated 'elevator' (the map's 'elevator1') to (-29.41, -50.28)" in result.output
    with NavigationDatabase(db_path) as db:
        assert db.current_map() == "glassgarden"
        on_map = {loc.name for loc in db.locations_on_map()}
    assert {"information desk", "waiting area", "elevator", "entrance 2", "cafeteria", "stairs"} <= on_map
    assert "waitingarea" not in on_map and "elevator1" not in on_map
    listed = run(db_path, "locations", "list").output.splitlines()
    assert listed[-1] == "map in use: glassgarden (places on other maps are not targets)"
