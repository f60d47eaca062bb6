"""The navigation database: defaults, lookups, validation, persistence and recovery."""

from __future__ import annotations

import logging
import math
import sqlite3
from dataclasses import dataclass, replace
from datetime import UTC, datetime, timedelta
from pathlib import Path
from zoneinfo import ZoneInfo

import pytest

from cyborg.errors import DatabaseError
from cyborg.navigation import content, schema
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.keywords import Intent, detect
from cyborg.navigation.models import CalendarEvent, Location, Response, ResponseType
from cyborg.navigation.schema import SCHEMA_VERSION

OSLO = ZoneInfo("Europe/Oslo")


@pytest.fixture
def db(tmp_path: Path) -> NavigationDatabase:
    return NavigationDatabase(tmp_path / "nav.db")


def at(year: int, month: int, day: int, hour: int = 0, minute: int = 0, second: int = 0) -> datetime:
    return datetime(year, month, day, hour, minute, second, tzinfo=OSLO)


def corrupt_files(path: Path) -> list[Path]:
    return sorted(
        p for p in path.parent.glob(path.name + ".corrupt-*") if not p.name.endswith(("-wal", "-shm"))
    )


# --- defaults --------------------------------------------------------------------------------


def test_new_database_has_the_default_places(db: NavigationDatabase) -> None:
    names = {loc.name for loc in db.list_locations()}
    assert names == {
        "information desk",
        "cafeteria",
        "entrance",
        "entrance 2",
        "el5",
        "el6",
        "waiting area",
        "elevator",
    }
    assert db.get_location("e16").name == "el6"
    assert db.get_location("info").name == "information desk"
    assert db.get_location("entrance2").name == "entrance 2"
    assert all(loc.position is None for loc in db.list_locations())  # no made-up (0, 0) poses


def test_a_fresh_database_has_no_target_until_places_get_a_pose(db: NavigationDatabase) -> None:
    """Issue 11.6: no map imported yet, "go to the cafeteria" must not mean "go to the map origin"."""
    assert db.current_map() is None
    assert db.locations_on_map() == []
    assert not any(db.is_target(loc) for loc in db.list_locations())
    assert "'cafeteria' has no pose" in db.no_pose_reason(db.get_location("cafeteria"))
    assert "cyborg db locations set-pose 'cafeteria' --x X --y Y" in db.no_pose_reason(
        db.get_location("canteen")
    )
    db.set_pose("canteen", 12.0, 3.5)  # by hand, on a base whose map never was imported
    cafe = db.get_location("cafeteria")
    assert cafe.position == (12.0, 3.5) and cafe.map == "" and cafe.aliases == ("canteen",)
    assert [loc.name for loc in db.locations_on_map()] == ["cafeteria"] and db.is_target(cafe)
    assert db.matcher(on_map=True).names == ["cafeteria"]


def test_set_pose_puts_a_place_on_the_map_in_use_and_keeps_the_rest(db: NavigationDatabase) -> None:
    event = db.add_event(CalendarEvent("el5", at(2024, 3, 20, 15), at(2024, 3, 20, 16)))
    db.use_map("campus")
    placed = db.set_pose("el5", 30.0, 43.5, heading=1.5)
    assert (placed.map, placed.position, placed.heading) == ("campus", (30.0, 43.5), 1.5)
    assert db.get_location("el5") == placed and db.is_target(placed)
    assert db.list_events("el5") == [event]
    assert db.set_pose("el6", 1.0, 2.0, map_name="glassgarden").map == "glassgarden"
    assert not db.is_target(db.get_location("el6"))  # a pose, but on another map
    with pytest.raises(DatabaseError, match="unknown location 'gym'"):
        db.set_pose("gym", 1.0, 2.0)


@pytest.mark.parametrize(
    ("kind", "emotion", "sentence"),
    [
        (ResponseType.OPINION, "neutral", "I am happy about cafeteria"),
        (ResponseType.OPINION, "curious", "What is this place? A el6 you say?"),
        (ResponseType.ARRIVED, "neutral", "Human, this is cafeteria"),
        (ResponseType.OFFER_GUIDE, "curious", "I think I know where that is, would you like me to show you?"),
        (ResponseType.CONFIRM, "elated", "At once."),
    ],
)
def test_default_responses_include_the_spec_scenarios(
    db: NavigationDatabase, kind: ResponseType, emotion: str, sentence: str
) -> None:
    place = "el6" if "el6" in sentence else "cafeteria"
    assert sentence in [r.say(place) for r in db.responses(kind, emotion)]


def test_every_response_type_has_a_sentence_for_any_emotion(db: NavigationDatabase) -> None:
    for kind in ResponseType:
        assert db.responses(kind, "some-new-emotion".replace("-", "_")), kind
        assert db.responses(kind, None), kind


def test_angry_robot_refuses_and_dislikes(db: NavigationDatabase) -> None:
    refusals = db.responses(ResponseType.REFUSE, "angry")
    assert refusals and all(r.emotion == "angry" for r in refusals)
    opinions = [r.say("cafeteria") for r in db.responses(ResponseType.OPINION, "angry")]
    assert "I hate the cafeteria." in opinions


def test_seeded_places_work_with_keyword_detection(db: NavigationDatabase) -> None:
    found = detect("where is the e16", db.matcher())
    assert found is not None and (found.intent, found.location) == (Intent.NAVIGATION_INFORMATION, "el6")


# --- locations -------------------------------------------------------------------------------


def test_lookup_is_case_insensitive_by_name_and_alias(db: NavigationDatabase) -> None:
    assert db.get_location("CAFETERIA").name == "cafeteria"
    assert db.get_location("  Information   Desk ").name == "information desk"
    assert db.get_location("E16").name == "el6"
    assert db.find_location("gym") is None


def test_unknown_location_error_names_it_and_suggests(db: NavigationDatabase) -> None:
    with pytest.raises(DatabaseError, match=r"unknown location 'cafetria'.*did you mean 'cafeteria'"):
        db.get_location("cafetria")


def test_add_update_remove_location(db: NavigationDatabase) -> None:
    gym = db.add_location(Location("gym", ("sports hall",), "glassgarden", 1.5, -2.0, 4.0, 0.3, True, 0.5))
    assert db.get_location("Sports Hall") == gym
    assert -math.pi <= gym.heading <= math.pi and math.isclose(gym.heading, 4.0 - 2 * math.pi)
    moved = db.update_location("gym", replace(gym, name="big gym", aliases=("hall",), x=9.0))
    assert db.get_location("hall") == moved
    assert db.find_location("sports hall") is None and db.find_location("gym") is None
    assert db.remove_location("HALL") == moved
    assert db.find_location("big gym") is None


@pytest.mark.parametrize(
    ("location", "message"),
    [
        (Location("Cafeteria"), r"'Cafeteria' is already used by location 'cafeteria'"),
        (Location("canteen 2", ("e16",)), r"'e16' is already used by location 'el6'"),
        (Location("Entrance-2"), r"'Entrance-2' is already used by location 'entrance 2'"),
        (Location("entrance two"), r"already used by location 'entrance 2'"),
        (Location("gym", ("gym",)), r"alias 'gym' of 'gym' repeats its name"),
        (Location("  ?! "), r"has no letters or digits"),
        (Location("gym", pleasantness=1.5), r"pleasantness=1.5 of 'gym' is outside -1..1"),
        (Location("gym", tolerance=0.0), r"tolerance=0.0 of 'gym' must be > 0"),
        (Location("gym", x=math.nan), r"x=nan of 'gym' is not a finite number"),
        (Location("gym", x=1.0), r"'gym' has x but no y; give both"),
        (Location("gym", y=1.0), r"'gym' has y but no x; give both"),
        (Location("gym", map="campus"), r"'gym' is on map 'campus' but has no x and y"),
    ],
)
def test_bad_locations_are_refused(db: NavigationDatabase, location: Location, message: str) -> None:
    before = db.list_locations()
    with pytest.raises(DatabaseError, match=message):
        db.add_location(location)
    assert db.list_locations() == before


def test_update_may_keep_its_own_name_but_not_take_another(db: NavigationDatabase) -> None:
    cafe = db.get_location("cafeteria")
    db.update_location("cafeteria", replace(cafe, pleasantness=-0.5))
    assert db.get_location("cafeteria").pleasantness == -0.5
    with pytest.raises(DatabaseError, match="already used by location 'elevator'"):
        db.update_location("cafeteria", replace(cafe, aliases=("lift",)))
    with pytest.raises(DatabaseError, match="unknown location 'gym'"):
        db.update_location("gym", cafe)


def test_location_with_events_is_only_removed_with_them(db: NavigationDatabase) -> None:
    event = db.add_event(CalendarEvent("cafeteria", at(2024, 3, 20, 15), at(2024, 3, 20, 16)))
    with pytest.raises(DatabaseError, match=rf"calendar events \[{event.id}\].*--with-events"):
        db.remove_location("cafeteria")
    assert db.list_events() == [event]
    db.remove_location("cafeteria", with_events=True)
    assert db.list_events() == []


# --- events ----------------------------------------------------------------------------------


def test_scenario_c_scheduled_cafeteria_visit_is_ongoing(db: NavigationDatabase) -> None:
    db.add_event(CalendarEvent("cafeteria", at(2024, 5, 6, 15, 0), at(2024, 5, 6, 15, 59), summary="coffee"))
    [ongoing] = db.ongoing_events(at(2024, 5, 6, 15, 29))
    assert ongoing.event.location == "cafeteria"
    assert (ongoing.start, ongoing.end) == (at(2024, 5, 6, 15, 0), at(2024, 5, 6, 15, 59))


@pytest.mark.parametrize(
    ("now", "expected"),
    [
        (at(2024, 5, 6, 14, 59, 59), False),
        (at(2024, 5, 6, 15, 0), True),  # start is inclusive
        (at(2024, 5, 6, 15, 58, 59), True),
        (at(2024, 5, 6, 15, 59), False),  # end is exclusive
        (datetime(2024, 5, 6, 13, 30, tzinfo=UTC), True),  # same instant in another zone
    ],
)
def test_ongoing_boundaries(db: NavigationDatabase, now: datetime, expected: bool) -> None:
    db.add_event(CalendarEvent("cafeteria", at(2024, 5, 6, 15, 0), at(2024, 5, 6, 15, 59)))
    assert bool(db.ongoing_events(now)) is expected


def test_ignored_events_are_stored_but_never_ongoing(db: NavigationDatabase) -> None:
    event = db.add_event(CalendarEvent("el5", at(2024, 5, 6, 10), at(2024, 5, 6, 12), ignored=True))
    assert db.list_events() == [event]
    assert db.ongoing_events(at(2024, 5, 6, 11)) == []
    db.update_event(event.id or 0, replace(event, ignored=False))
    assert [o.event.location for o in db.ongoing_events(at(2024, 5, 6, 11))] == ["el5"]


def test_recurring_event_is_ongoing_on_later_weeks(db: NavigationDatabase) -> None:
    db.add_event(
        CalendarEvent("el6", at(2024, 5, 6, 10), at(2024, 5, 6, 12), recurrence="FREQ=WEEKLY;COUNT=3")
    )
    assert db.ongoing_events(at(2024, 5, 13, 11))
    assert db.ongoing_events(at(2024, 5, 20, 11))
    assert not db.ongoing_events(at(2024, 5, 27, 11))  # COUNT=3 is over
    assert not db.ongoing_events(at(2024, 5, 14, 11))


def test_event_is_stored_in_utc_and_read_back_in_its_zone(db: NavigationDatabase, tmp_path: Path) -> None:
    event = db.add_event(CalendarEvent("el5", at(2024, 7, 1, 9), at(2024, 7, 1, 10)))
    with sqlite3.connect(tmp_path / "nav.db") as raw:
        [(start, zone)] = raw.execute("SELECT start_utc, timezone FROM events").fetchall()
    assert (start, zone) == ("2024-07-01T07:00:00+00:00", "Europe/Oslo")
    assert db.get_event(event.id or 0).start.tzinfo == OSLO


@pytest.mark.parametrize(
    ("event", "message"),
    [
        (CalendarEvent("gym", at(2024, 1, 1, 9), at(2024, 1, 1, 10)), "unknown location 'gym'"),
        (CalendarEvent("el5", at(2024, 1, 1, 10), at(2024, 1, 1, 9)), "is not after start"),
        (CalendarEvent("el5", at(2024, 1, 1, 10), at(2024, 1, 1, 10)), "is not after start"),
        (
            CalendarEvent("el5", datetime(2024, 1, 1, 9), at(2024, 1, 1, 10)),
            "start 2024-01-01T09:00:00 has no time zone",
        ),
        (
            CalendarEvent("el5", at(2024, 1, 1, 9), at(2024, 1, 1, 10), recurrence="FREQ=SOMETIMES"),
            "SOMETIMES",
        ),
    ],
)
def test_bad_events_are_refused(db: NavigationDatabase, event: CalendarEvent, message: str) -> None:
    with pytest.raises(DatabaseError, match=message):
        db.add_event(event)
    assert db.list_events() == []


def test_uid_is_unique_and_upsert_updates_keeping_ignored(db: NavigationDatabase) -> None:
    first = db.add_event(CalendarEvent("el5", at(2024, 1, 1, 9), at(2024, 1, 1, 10), ignored=True, uid="u1"))
    with pytest.raises(DatabaseError, match="uid 'u1' exists"):
        db.add_event(CalendarEvent("el6", at(2024, 1, 2, 9), at(2024, 1, 2, 10), uid="u1"))
    [(updated, created)] = db.upsert_events(
        [CalendarEvent("el6", at(2024, 1, 2, 9), at(2024, 1, 2, 10), uid="u1")]
    )
    assert not created and updated.id == first.id and updated.ignored
    assert db.list_events() == [updated]
    assert updated.location == "el6"


def test_remove_event_and_missing_ids(db: NavigationDatabase) -> None:
    event = db.add_event(CalendarEvent("el5", at(2024, 1, 1, 9), at(2024, 1, 1, 10)))
    assert db.remove_event(event.id or 0) == event
    with pytest.raises(DatabaseError, match=f"no calendar event with id {event.id}"):
        db.remove_event(event.id or 0)


def test_naive_now_is_refused(db: NavigationDatabase) -> None:
    with pytest.raises(ValueError, match="naive"):
        db.ongoing_events(datetime(2024, 1, 1, 9))


# --- responses -------------------------------------------------------------------------------


def test_responses_fall_back_to_any_emotion(db: NavigationDatabase) -> None:
    db.add_response(Response("I adore the LOCATION", ResponseType.ARRIVED, "elated"))
    assert [r.sentence for r in db.responses(ResponseType.ARRIVED, "elated")] == ["I adore the LOCATION"]
    assert [r.sentence for r in db.responses(ResponseType.ARRIVED, "Elated")] == ["I adore the LOCATION"]
    assert [r.sentence for r in db.responses(ResponseType.ARRIVED, "curious")] == ["Human, this is LOCATION"]
    assert [r.sentence for r in db.responses(ResponseType.ARRIVED, None)] == ["Human, this is LOCATION"]


def test_response_synonyms_and_removal(db: NavigationDatabase) -> None:
    added = db.add_response(Response("The LOCATION   is grey.", ResponseType.OPINION, "Inhibited"))
    assert (added.sentence, added.emotion) == ("The LOCATION is grey.", "inhibited")
    assert added in db.list_responses(ResponseType.OPINION, "inhibited")
    assert db.remove_response(added.id or 0) == added
    assert added not in db.list_responses()


@pytest.mark.parametrize(
    ("response", "message"),
    [
        (Response("I like it here", ResponseType.OPINION), "lacks the placeholder LOCATION"),
        (Response("I am stuck", ResponseType.STUCK, "inhibited"), "lacks the placeholder LOCATION"),
        (Response("   ", ResponseType.CONFIRM), "empty"),
        (Response("At once.", ResponseType.CONFIRM), r"exists already \(id \d+\)"),
        (Response("Fine.", ResponseType.CONFIRM, "very angry!"), "emotion 'very angry!' is not a name"),
    ],
)
def test_bad_responses_are_refused(db: NavigationDatabase, response: Response, message: str) -> None:
    before = db.list_responses()
    with pytest.raises(DatabaseError, match=message):
        db.add_response(response)
    assert db.list_responses() == before


def test_confirmation_may_omit_the_place(db: NavigationDatabase) -> None:
    added = db.add_response(Response("Right away!", ResponseType.CONFIRM, "elated"))
    assert db.responses(ResponseType.CONFIRM, "elated") == [added]
    assert added.say("cafeteria") == "Right away!"


# --- persistence and recovery ------------------------------------------------------------------


def test_everything_persists_across_reopen(tmp_path: Path) -> None:
    path = tmp_path / "nav.db"
    with NavigationDatabase(path) as db:
        gym = db.add_location(Location("gym", ("hall",), "m", 1.0, 2.0, 0.5, 0.4, True, -0.2))
        event = db.add_event(
            CalendarEvent(
                "gym", at(2024, 3, 1, 8), at(2024, 3, 1, 9), recurrence="FREQ=DAILY", summary="s", uid="u"
            )
        )
        response = db.add_response(Response("LOCATION again?", ResponseType.OPINION, "bored"))
        db.remove_location("elevator")
    with NavigationDatabase(path) as db:
        assert db.get_location("hall") == gym
        assert db.list_events() == [event]
        assert response in db.responses(ResponseType.OPINION, "bored")
        assert db.find_location("elevator") is None  # defaults are not re-seeded


def test_committed_write_is_visible_to_another_connection_at_once(
    db: NavigationDatabase, tmp_path: Path
) -> None:
    db.add_location(Location("gym"))
    with sqlite3.connect(tmp_path / "nav.db") as raw:
        assert raw.execute("SELECT COUNT(*) FROM locations WHERE name = 'gym'").fetchone() == (1,)
        assert raw.execute("PRAGMA journal_mode").fetchone() == ("wal",)
        assert raw.execute("PRAGMA user_version").fetchone() == (SCHEMA_VERSION,)


def test_not_a_database_is_moved_aside(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "nav.db"
    path.write_bytes(b"this is not sqlite " * 200)
    with caplog.at_level(logging.WARNING, logger="cyborg.navigation.database"):
        db = NavigationDatabase(path)
    [aside] = corrupt_files(path)
    assert aside.read_bytes().startswith(b"this is not sqlite")
    assert db.get_location("cafeteria").name == "cafeteria"
    assert any("unusable" in r.getMessage() and str(aside) in r.getMessage() for r in caplog.records)
    db.close()


def test_damaged_database_fails_integrity_check_and_is_moved_aside(tmp_path: Path) -> None:
    path = tmp_path / "nav.db"
    with NavigationDatabase(path) as db:
        for i in range(300):
            db.add_location(Location(f"room {i}", (f"r{i}",), "map", float(i), 1.0))
    with sqlite3.connect(path) as raw:
        raw.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    data = bytearray(path.read_bytes())
    page = 4096
    for offset in range(2 * page, len(data) - page, page):
        data[offset : offset + 16] = b"\xff" * 16  # clobber every page header but the first
    path.write_bytes(bytes(data))
    with NavigationDatabase(path) as db:
        assert db.find_location("room 1") is None
        assert db.find_location("cafeteria") is not None
    assert len(corrupt_files(path)) == 1


def test_failing_integrity_check_is_moved_aside(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "nav.db"
    with NavigationDatabase(path) as db:
        db.add_location(Location("gym"))
    with sqlite3.connect(path) as raw:  # orphan the index's pages: readable, but not intact
        raw.execute("PRAGMA writable_schema=ON")
        raw.execute("DELETE FROM sqlite_master WHERE name = 'responses_by_type'")
    with caplog.at_level(logging.WARNING), NavigationDatabase(path) as db:
        assert db.find_location("gym") is None
        assert db.find_location("cafeteria") is not None
    assert "integrity_check failed" in caplog.text
    assert len(corrupt_files(path)) == 1


def test_foreign_sqlite_file_is_moved_aside(tmp_path: Path) -> None:
    path = tmp_path / "nav.db"
    with sqlite3.connect(path) as raw:
        raw.execute("CREATE TABLE photos (id INTEGER)")
    with NavigationDatabase(path) as db:
        assert db.find_location("cafeteria") is not None
    assert len(corrupt_files(path)) == 1


def test_empty_file_is_initialised_without_moving_it(tmp_path: Path) -> None:
    path = tmp_path / "nav.db"
    path.touch()
    with NavigationDatabase(path) as db:
        assert db.find_location("cafeteria") is not None
    assert corrupt_files(path) == []


def test_newer_schema_is_refused_and_left_alone(tmp_path: Path) -> None:
    path = tmp_path / "nav.db"
    NavigationDatabase(path).close()
    with sqlite3.connect(path) as raw:
        raw.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    with pytest.raises(DatabaseError, match=f"schema version {SCHEMA_VERSION + 1}, newer"):
        NavigationDatabase(path)
    assert corrupt_files(path) == []


def test_older_schema_is_migrated_keeping_data(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "nav.db"
    with NavigationDatabase(path) as db:
        db.add_location(Location("gym"))
    step = ("CREATE TABLE visits (id INTEGER PRIMARY KEY)",)
    monkeypatch.setattr(schema, "MIGRATIONS", (*schema.MIGRATIONS, step))
    monkeypatch.setattr(schema, "SCHEMA_VERSION", SCHEMA_VERSION + 1)
    with NavigationDatabase(path) as db:
        assert db.find_location("gym") is not None
    with sqlite3.connect(path) as raw:
        assert raw.execute("PRAGMA user_version").fetchone() == (SCHEMA_VERSION + 1,)
        assert raw.execute("SELECT COUNT(*) FROM visits").fetchone() == (0,)


def test_hand_edited_nonsense_is_skipped_not_fatal(
    db: NavigationDatabase, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    good = db.add_event(CalendarEvent("el5", at(2024, 1, 1, 9), at(2024, 1, 1, 10)))
    with sqlite3.connect(tmp_path / "nav.db") as raw:
        raw.execute(
            "INSERT INTO events (location_id, start_utc, end_utc, timezone) "
            "SELECT id, 'yesterday', 'today', 'Europe/Oslo' FROM locations WHERE name = 'el6'"
        )
        raw.execute("INSERT INTO responses (sentence, type, emotion) VALUES ('LOCATION!', 'shout', NULL)")
    with caplog.at_level(logging.WARNING):
        assert db.list_events() == [good]
        assert all(r.sentence != "LOCATION!" for r in db.list_responses())
        assert db.ongoing_events(at(2024, 1, 1, 9, 30))[0].event == good
    assert "skipping calendar event" in caplog.text and "unknown type 'shout'" in caplog.text


def test_folder_path_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(DatabaseError, match="is a folder"):
        NavigationDatabase(tmp_path)


def test_events_between_lists_occurrences_in_order(db: NavigationDatabase) -> None:
    db.add_event(
        CalendarEvent("el5", at(2024, 5, 6, 10), at(2024, 5, 6, 11), recurrence="FREQ=DAILY;COUNT=5")
    )
    db.add_event(CalendarEvent("cafeteria", at(2024, 5, 7, 12), at(2024, 5, 7, 13)))
    found = db.events_between(at(2024, 5, 7, 0), at(2024, 5, 7, 0) + timedelta(days=2))
    assert [(o.event.location, o.start) for o in found] == [
        ("el5", at(2024, 5, 7, 10)),
        ("cafeteria", at(2024, 5, 7, 12)),
        ("el5", at(2024, 5, 8, 10)),
    ]


# --- maps: the map in use and importing its goals ------------------------------------------


@dataclass(frozen=True)
class Goal:
    name: str
    x: float
    y: float
    theta: float = 0.0


GLASSGARDEN_GOALS = (
    Goal("waitingarea", -33.581, 10.627),
    Goal("info", -33.505, 1.139),
    Goal("hallway", -30.251, -79.089),
    Goal("elevator1", -29.414, -50.281),
    Goal("elevator2", -21.912, -42.451),
    Goal("entrance2", -18.246, -65.898),
    Goal("hallway1", 1.102, -6.031),
    Goal("stairs", -31.494, -71.056),
)


def test_map_goals_named_like_default_places_place_them(db: NavigationDatabase) -> None:
    lines = [db.import_pose(goal, "glassgarden") for goal in GLASSGARDEN_GOALS]
    assert lines[0] == "updated 'waiting area' (the map's 'waitingarea') to (-33.58, 10.63)"
    waiting, elevator = db.get_location("waiting area"), db.get_location("elevator")
    assert (waiting.x, waiting.y, waiting.map) == (-33.581, 10.627, "glassgarden")
    assert waiting.crowded and waiting.pleasantness == 0.4  # the default's knowledge is kept
    assert (elevator.x, elevator.y) == (-29.414, -50.281)  # elevator1: the first elevator
    assert db.get_location("elevator1") == elevator and db.get_location("waitingarea") == waiting
    assert db.get_location("elevator2").name == "elevator2"  # the second one is a place of its own
    assert db.get_location("info").x == -33.505 and db.get_location("entrance 2").y == -65.898
    assert db.get_location("hallway1").x == 1.102 and db.get_location("hallway").x == -30.251
    assert not {"waitingarea", "elevator1", "info", "entrance2"} & {loc.name for loc in db.list_locations()}


def test_importing_the_same_map_again_moves_the_same_places(db: NavigationDatabase) -> None:
    for _ in range(2):
        for goal in GLASSGARDEN_GOALS:
            db.import_pose(goal, "glassgarden")
    assert len(db.list_locations()) == 8 + 4  # the defaults, plus hallway, hallway1, elevator2, stairs
    assert db.get_location("waiting area").aliases == ("waitingarea",)


def test_the_speech_matcher_of_the_map_finds_the_default_names(db: NavigationDatabase) -> None:
    for goal in GLASSGARDEN_GOALS:
        db.import_pose(goal, "glassgarden")
    matcher = db.matcher(on_map=True)
    for text, place in [
        ("the waiting area", "waiting area"),
        ("the elevator", "elevator"),
        ("elevator 2", "elevator2"),
    ]:
        found = matcher.find(text)
        assert found is not None and found.location == place, text


def test_only_places_on_the_imported_map_are_on_the_map(db: NavigationDatabase) -> None:
    assert db.current_map() is None
    db.add_location(Location("dock", x=0.0, y=0.0))  # a pose given by hand, at the map origin
    assert [loc.name for loc in db.locations_on_map()] == ["dock"]  # before any map: those with a pose
    for goal in GLASSGARDEN_GOALS:
        db.import_pose(goal, "glassgarden")
    assert db.current_map() == "glassgarden"
    on_map = {loc.name for loc in db.locations_on_map()}
    assert "stairs" in on_map and "waiting area" in on_map
    assert not on_map & {"cafeteria", "el5", "el6", "entrance", "dock"}  # no pose, or not on this map
    assert not db.on_current_map(db.get_location("cafeteria"))
    db.import_pose(Goal("cafeteria", 66.0, 2.0), "campus")
    assert db.current_map() == "campus"
    assert [loc.name for loc in db.locations_on_map()] == ["cafeteria"]
    assert "stairs" not in db.matcher(on_map=True).names
    assert "on map 'glassgarden', not on the map in use ('campus')" in db.off_map_reason(
        db.get_location("stairs")
    )


def test_the_map_in_use_persists_and_needs_a_name(tmp_path: Path) -> None:
    with NavigationDatabase(tmp_path / "nav.db") as db:
        db.use_map("campus")
        with pytest.raises(DatabaseError, match="map name is empty"):
            db.use_map("  ")
    with NavigationDatabase(tmp_path / "nav.db") as db:
        assert db.current_map() == "campus"


def old_file(path: Path, version: int) -> None:
    """A file as cyborg wrote it at schema ``version`` (1 or 2): default places at (0, 0) on no map."""
    with sqlite3.connect(path) as raw:
        for step in schema.MIGRATIONS[:version]:
            for sql in step:
                raw.execute(sql)
        for place in content.DEFAULT_LOCATIONS:
            cursor = raw.execute(
                "INSERT INTO locations (name, map, x, y, heading, tolerance, crowded, pleasantness) "
                "VALUES (?, '', 0, 0, 0, ?, ?, ?)",
                (place.name, place.tolerance, int(place.crowded), place.pleasantness),
            )
            raw.executemany(
                "INSERT INTO location_aliases (alias, location_id) VALUES (?, ?)",
                [(alias, cursor.lastrowid) for alias in place.aliases],
            )
        later = {kind for v, kinds in schema.NEW_RESPONSE_TYPES.items() if v > version for kind in kinds}
        raw.executemany(
            "INSERT INTO responses (sentence, type, emotion) VALUES (?, ?, ?)",
            [(r.sentence, r.type.value, r.emotion) for r in content.DEFAULT_RESPONSES if r.type not in later],
        )
        raw.execute(f"PRAGMA user_version = {version}")
    raw.close()


def test_a_version_1_file_gains_the_map_setting_and_the_not_on_map_sentence(tmp_path: Path) -> None:
    path = tmp_path / "nav.db"
    old_file(path, 1)
    with sqlite3.connect(path) as raw:
        raw.execute("INSERT INTO locations (name, map, x, y) VALUES ('gym', 'campus', 3, 4)")
    raw.close()
    with NavigationDatabase(path) as db:
        assert (db.get_location("gym").map, db.get_location("gym").position) == ("campus", (3.0, 4.0))
        assert db.current_map() is None
        assert [r.say("gym") for r in db.responses(ResponseType.NOT_ON_MAP, "elated")] == [
            "I know the gym, but it is not on the map I have here."
        ]
    with sqlite3.connect(path) as raw:
        assert raw.execute("PRAGMA user_version").fetchone() == (SCHEMA_VERSION,)
    raw.close()


def test_a_version_2_file_keeps_its_data_and_its_placeholder_poses_become_no_pose(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Issue 11.6: the (0, 0) placeholders of an existing file stop being targets; nothing else changes."""
    path = tmp_path / "nav.db"
    old_file(path, 2)
    with sqlite3.connect(path) as raw:
        raw.execute("INSERT INTO settings (key, value) VALUES ('current_map', 'campus')")
        raw.execute("UPDATE locations SET pleasantness = -0.5 WHERE name = 'cafeteria'")  # edited by hand
        raw.execute("UPDATE locations SET map = 'campus', x = 30, y = 43.5, heading = 1 WHERE name = 'el5'")
        raw.execute("INSERT INTO locations (name, map, x, y) VALUES ('dock', 'campus', 0, 0)")  # map origin
        raw.execute("INSERT INTO locations (name, x, y) VALUES ('kiosk', 2.5, -1)")  # by hand, no map
        raw.execute(
            "INSERT INTO location_aliases (alias, location_id) SELECT 'bay', id FROM locations WHERE name = 'dock'"
        )
        raw.execute(
            "INSERT INTO events (location_id, start_utc, end_utc, timezone, uid) SELECT id, "
            "'2024-03-20T14:00:00+00:00', '2024-03-20T15:00:00+00:00', 'Europe/Oslo', 'lunch' "
            "FROM locations WHERE name = 'cafeteria'"
        )
        raw.execute(
            "INSERT INTO responses (sentence, type, emotion) VALUES ('Yum, LOCATION.', 'opinion', NULL)"
        )
        responses_before = raw.execute(
            "SELECT id, sentence, type, emotion FROM responses ORDER BY id"
        ).fetchall()
    raw.close()
    with caplog.at_level(logging.WARNING), NavigationDatabase(path) as db:
        places = {loc.name: loc for loc in db.list_locations()}
        cafe = places["cafeteria"]
        assert cafe.position is None and cafe.map == "" and not db.is_target(cafe)
        assert (cafe.aliases, cafe.crowded, cafe.pleasantness) == (("canteen",), True, -0.5)
        assert [e.uid for e in db.list_events("cafeteria")] == ["lunch"]
        assert (places["el5"].position, places["el5"].map, places["el5"].heading) == (
            (30.0, 43.5),
            "campus",
            1.0,
        )
        assert (places["dock"].position, places["dock"].aliases) == ((0.0, 0.0), ("bay",))
        assert places["kiosk"].position == (2.5, -1.0)
        assert len(places) == 8 + 2
        assert {p.name for p in places.values() if p.position is None} == {
            p.name for p in content.DEFAULT_LOCATIONS
        } - {"el5"}
        assert [loc.name for loc in db.locations_on_map()] == ["dock", "el5"]
        assert db.current_map() == "campus"
        with pytest.raises(DatabaseError, match="has calendar events"):
            db.remove_location("cafeteria")  # the events still point at it
        assert [r.say("gym") for r in db.responses(ResponseType.NO_POSE, None)] == [
            "I have heard of the gym, but I do not know where it is."
        ]
        assert db.responses(ResponseType.RESUME, None)
        assert [r.say("gym") for r in db.responses(ResponseType.ASK_GO, None)] == ["Shall I go to the gym?"]
    with sqlite3.connect(path) as raw:
        assert raw.execute("PRAGMA user_version").fetchone() == (SCHEMA_VERSION,)
        kept = raw.execute(
            "SELECT id, sentence, type, emotion FROM responses WHERE type NOT IN ('no_pose', 'resume', 'ask_go', 'did_you_mean') ORDER BY id"
        ).fetchall()
        assert kept == responses_before
        assert raw.execute("PRAGMA foreign_key_check").fetchall() == []
    raw.close()
    assert "had the (0, 0) placeholder pose and no map" in caplog.text
    assert "cafeteria, el6, elevator" in caplog.text and "dock" not in caplog.text
    assert "cyborg db locations set-pose NAME --x X --y Y" in caplog.text
