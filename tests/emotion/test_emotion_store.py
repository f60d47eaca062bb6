"""The controller store keeps its data across reopen and survives a broken file."""

from __future__ import annotations

import logging
import sqlite3
import threading
import time
from contextlib import closing
from pathlib import Path
from typing import Any

import pytest

from cyborg.emotion.model import PAD
from cyborg.errors import DatabaseError, InvalidValueError
from cyborg.motivator.logic import MotivationalEvent
from cyborg.motivator.store import ControllerStore

NAVIGATION = MotivationalEvent(
    state="idle", event="navigation_emotional", reward_arousal=0.05, reward_dominance=-0.01
)
MUSIC = MotivationalEvent(state="idle", event="music_play", reward_pleasure=0.05, event_cost=0.2)
JOKE = MotivationalEvent(state="conversation", event="joke_tell", reward_pleasure=0.02)


def corrupt_files(path: Path) -> list[Path]:
    return sorted(path.parent.glob(path.name + ".corrupt-*"))


def test_new_store_has_defaults_and_seeded_events(tmp_path: Path) -> None:
    with ControllerStore(tmp_path / "sub" / "c.db", [NAVIGATION, MUSIC, JOKE]) as store:
        stored = store.get_emotion()
        assert (stored.pad, stored.updated_at, stored.enabled) == (PAD(), None, True)
        assert store.get_saturations() == {}
        assert store.list_events("idle") == [MUSIC, NAVIGATION]
        assert store.list_events() == [JOKE, MUSIC, NAVIGATION]


def test_everything_persists_across_reopen(tmp_path: Path) -> None:
    path = tmp_path / "c.db"
    with ControllerStore(path, [NAVIGATION]) as store:
        store.save_emotion(PAD(0.1, -0.2, 0.3), 1234.5)
        store.set_emotion_enabled(False)
        store.save_saturations({"navigation_emotional": 0.33, "music_play": 0.0})
        store.add_event(MUSIC)
        store.add_event(JOKE)
        assert store.remove_event("conversation", "joke_tell")
        assert not store.remove_event("conversation", "joke_tell")
    with ControllerStore(path, [NAVIGATION, JOKE]) as store:
        stored = store.get_emotion()
        assert (stored.pad, stored.updated_at, stored.enabled) == (PAD(0.1, -0.2, 0.3), 1234.5, False)
        assert store.get_saturations() == {"music_play": 0.0, "navigation_emotional": 0.33}
        # seeding happens only when the file is created: the removed joke stays removed
        assert store.list_events() == [MUSIC, NAVIGATION]


def test_add_event_replaces_the_same_name_in_the_same_state(tmp_path: Path) -> None:
    with ControllerStore(tmp_path / "c.db", [NAVIGATION]) as store:
        stronger = NAVIGATION.model_copy(update={"reward_arousal": 0.2})
        store.add_event(stronger)
        assert store.list_events("idle") == [stronger]


def test_save_saturations_replaces_the_whole_set(tmp_path: Path) -> None:
    with ControllerStore(tmp_path / "c.db") as store:
        store.save_saturations({"a": 0.5, "b": 0.2})
        store.save_saturations({"b": 0.1})
        assert store.get_saturations() == {"b": 0.1}


def test_writes_are_visible_to_another_connection_at_once(tmp_path: Path) -> None:
    path = tmp_path / "c.db"
    with ControllerStore(path) as store:
        store.save_emotion(PAD(0.5, 0.0, 0.0), 10.0)
        other = sqlite3.connect(path)
        try:
            assert other.execute("SELECT pleasure, updated_at FROM emotion").fetchone() == (0.5, 10.0)
            assert other.execute("PRAGMA journal_mode").fetchone() == ("wal",)
        finally:
            other.close()
        # synchronous is per connection, so look at the store's own (2 = FULL)
        assert store._conn.execute("PRAGMA synchronous").fetchone() == (2,)


def test_garbage_file_is_moved_aside_and_recreated(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "c.db"
    path.write_bytes(b"this is not sqlite at all " * 200)
    with caplog.at_level(logging.WARNING), ControllerStore(path, [NAVIGATION]) as store:
        assert store.list_events() == [NAVIGATION]
        assert store.get_emotion().pad == PAD()
    [aside] = corrupt_files(path)
    assert aside.read_bytes().startswith(b"this is not sqlite")
    assert "unusable" in caplog.text and str(aside) in caplog.text


def test_database_of_another_schema_is_moved_aside(tmp_path: Path) -> None:
    path = tmp_path / "c.db"
    conn = sqlite3.connect(path)
    conn.execute("CREATE TABLE locations (name TEXT)")
    conn.commit()
    conn.close()
    with ControllerStore(path) as store:
        store.save_emotion(PAD(0.2, 0.2, 0.2), 1.0)
    assert len(corrupt_files(path)) == 1


def test_damaged_pages_are_detected_and_recovered(tmp_path: Path) -> None:
    path = tmp_path / "c.db"
    with ControllerStore(path, [NAVIGATION]) as store:
        for i in range(300):
            store.add_event(MUSIC.model_copy(update={"event": f"event_{i:03d}_" + "x" * 40}))
    data = bytearray(path.read_bytes())
    assert len(data) > 8192
    data[4096:8192] = b"\xff" * 4096  # trash the second page, keep the header
    path.write_bytes(bytes(data))
    with ControllerStore(path, [NAVIGATION]) as store:
        assert store.list_events() == [NAVIGATION]
    assert len(corrupt_files(path)) == 1


def test_two_corruptions_in_the_same_second_do_not_overwrite_each_other(tmp_path: Path) -> None:
    path = tmp_path / "c.db"
    for _ in range(2):
        path.write_bytes(b"junk" * 1000)
        ControllerStore(path).close()
    assert len(corrupt_files(path)) == 2


def test_hand_edited_nonsense_is_tolerated(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "c.db"
    ControllerStore(path, [NAVIGATION]).close()
    conn = sqlite3.connect(path)
    conn.execute("UPDATE emotion SET pleasure = 7.0, arousal = 'lots'")
    conn.execute("INSERT INTO saturations VALUES ('a', 3.0), ('b', 'x')")
    conn.execute("INSERT INTO events VALUES ('idle', 'bad', 5.0, 0, 0, NULL)")
    conn.commit()
    conn.close()
    with caplog.at_level(logging.WARNING), ControllerStore(path) as store:
        assert store.get_emotion().pad == PAD(1.0, 0.0, 0.0)
        assert store.get_saturations() == {"a": 1.0, "b": 0.0}
        assert store.list_events() == [NAVIGATION]
    assert "skipping invalid motivational event" in caplog.text


def test_a_folder_path_is_refused_with_a_fix(tmp_path: Path) -> None:
    with pytest.raises(DatabaseError, match="is a folder"):
        ControllerStore(tmp_path)


class _SlowDisk(sqlite3.Connection):
    """A connection whose COMMIT waits until the test lets it go (a disk slow to flush)."""

    gate: threading.Event
    commits = 0

    def execute(self, sql: str, parameters: Any = (), /) -> sqlite3.Cursor:
        if sql.strip().upper() == "COMMIT":
            assert self.gate.wait(10), "the test never let the commit go"
            type(self).commits += 1
        return super().execute(sql, parameters)


def test_write_behind_saves_never_wait_for_the_disk_and_the_latest_value_is_stored(tmp_path: Path) -> None:
    """Issue 18: the controller's loop hands saves to the store's thread; a burst is one or two commits."""
    path = tmp_path / "c.db"
    store = ControllerStore(path, write_behind=True)
    _SlowDisk.gate = threading.Event()
    assert store._write_conn is not None
    store._write_conn.close()
    store._write_conn = sqlite3.connect(
        path, isolation_level=None, factory=_SlowDisk, check_same_thread=False
    )
    try:
        for step in range(1, 51):  # the first commit hangs on the "disk": none of these may wait for it
            assert store.save_emotion(PAD(step / 100, 0.0, 0.0), float(step)) is True
        assert store.save_status.saved and store.save_status.unsaved == ()  # nothing failed: nothing to say
        _SlowDisk.gate.set()
        stored = store.get_emotion()  # waits for the writes queued before it
        assert stored.pad.pleasure == pytest.approx(0.5) and stored.updated_at == 50.0
        assert 1 <= _SlowDisk.commits <= 2, _SlowDisk.commits
    finally:
        _SlowDisk.gate.set()
        store.close()
    assert ControllerStore(path).get_emotion().pad.pleasure == pytest.approx(0.5)


def test_write_behind_close_writes_what_waits(tmp_path: Path) -> None:
    path = tmp_path / "c.db"
    store = ControllerStore(path, write_behind=True)
    store.save_saturations({"music_play": 0.25})
    store.set_emotion_enabled(False)
    store.close()
    reopened = ControllerStore(path)
    assert reopened.get_saturations() == {"music_play": 0.25} and reopened.get_emotion().enabled is False
    reopened.close()


class _CountingDisk(sqlite3.Connection):
    commits = 0

    def execute(self, sql: str, parameters: Any = (), /) -> sqlite3.Cursor:
        if sql.strip().upper() == "COMMIT":
            type(self).commits += 1
        return super().execute(sql, parameters)


def _stored_pleasure(path: Path) -> float:
    """What a restart would read now (another connection, not the store's)."""
    with closing(sqlite3.connect(path)) as conn:
        return float(conn.execute("SELECT pleasure FROM emotion").fetchone()[0])


def test_write_behind_saves_of_one_moment_share_a_commit_and_reads_do_not_wait_out_the_window(
    tmp_path: Path,
) -> None:
    """Issue 18: a virtual clock saves the emotion thousands of times a real second; the store's
    thread gathers them for its commit window, but a read or closing commits at once."""
    path = tmp_path / "c.db"
    store = ControllerStore(path, write_behind=True, commit_window=120.0)
    assert store._write_conn is not None
    store._write_conn.close()
    store._write_conn = sqlite3.connect(
        path, isolation_level=None, factory=_CountingDisk, check_same_thread=False
    )
    _CountingDisk.commits = 0
    try:
        for step in range(1, 21):
            assert store.save_emotion(PAD(step / 100, 0.0, 0.0), float(step)) is True
        assert _stored_pleasure(path) == 0.0 and _CountingDisk.commits == 0  # still gathering
        started = time.monotonic()
        assert store.get_emotion().pad.pleasure == pytest.approx(0.2)
        assert time.monotonic() - started < 60, "the read waited out the 120 s window"
        assert _CountingDisk.commits == 1 and _stored_pleasure(path) == pytest.approx(0.2)
        store.save_emotion(PAD(0.3, 0.0, 0.0), 21.0)
    finally:
        started = time.monotonic()
        store.close()
    assert time.monotonic() - started < 60, "closing waited out the 120 s window"
    assert _stored_pleasure(path) == pytest.approx(0.3)


def test_write_behind_without_a_window_commits_each_save_at_once(tmp_path: Path) -> None:
    """A real robot's store (no commit window): a save is on disk without a read or closing, so
    a crash right after it (kill -9) loses nothing but the write in flight."""
    path = tmp_path / "c.db"
    store = ControllerStore(path, write_behind=True)
    try:
        store.save_emotion(PAD(0.4, 0.0, 0.0), 1.0)
        deadline = time.monotonic() + 10
        while _stored_pleasure(path) != pytest.approx(0.4):
            assert time.monotonic() < deadline, "the save waited for something"
            time.sleep(0.005)
    finally:
        store.close()


@pytest.mark.parametrize("window", [-0.1, float("nan")])
def test_a_bad_commit_window_is_refused_with_the_fix(tmp_path: Path, window: float) -> None:
    with pytest.raises(InvalidValueError, match=r"commit_window .* fix: pass e\.g\. 0\.02"):
        ControllerStore(tmp_path / "c.db", write_behind=True, commit_window=window)
    assert not (tmp_path / "c.db").exists()


def test_events_another_program_adds_while_the_robot_runs_are_seen(tmp_path: Path) -> None:
    """The motivator reads the events at every decision; the store keeps them until the file changes."""
    path = tmp_path / "c.db"
    with ControllerStore(path, [NAVIGATION]) as store:
        assert [e.event for e in store.list_events("idle")] == ["navigation_emotional"]
        with ControllerStore(path) as other:  # e.g. an sqlite3 shell on the robot
            other.add_event(MUSIC)
        assert [e.event for e in store.list_events("idle")] == ["music_play", "navigation_emotional"]
        assert store.remove_event("idle", "music_play")
        store.add_event(JOKE)
        assert [e.event for e in store.list_events()] == ["joke_tell", "navigation_emotional"]
        assert store.list_events("conversation") == [JOKE]
