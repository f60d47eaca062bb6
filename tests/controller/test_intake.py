"""The controller's event queue: bounded by size and age, each sender in its own line."""

from __future__ import annotations

from cyborg.controller.intake import DropCounter, DropReason, EventIntake, QueuedEvent


def names(intake: EventIntake, now: float) -> list[str]:
    taken = []
    while (event := intake.take(now)[0]) is not None:
        taken.append(f"{event.sender}:{event.name}")
    return taken


def test_senders_take_turns_so_one_event_waits_behind_at_most_one_of_each_flooder() -> None:
    intake = EventIntake(size=100, max_age=10.0)
    for n in range(5):
        intake.offer(QueuedEvent(f"f{n}", "flooder", 0.0))
    intake.offer(QueuedEvent("music_play", "person", 0.0))
    assert names(intake, 0.0) == [
        "flooder:f0",
        "person:music_play",
        "flooder:f1",
        "flooder:f2",
        "flooder:f3",
        "flooder:f4",
    ]


def test_a_full_queue_drops_the_fullest_senders_oldest_event_not_a_persons() -> None:
    intake = EventIntake(size=3, max_age=10.0)
    for n in range(3):
        assert intake.offer(QueuedEvent(f"f{n}", "flooder", 0.0)) is None
    own = QueuedEvent("f3", "flooder", 0.0)
    assert intake.offer(own) is own  # the flooder's own newcomer waits no longer than its oldest
    dropped = intake.offer(QueuedEvent("stop", "person", 0.0))
    assert dropped is not None and dropped.name == "f0"
    assert len(intake) == 3 and names(intake, 0.0) == ["flooder:f1", "person:stop", "flooder:f2"]


def test_an_event_taken_supersedes_the_older_backlog_of_other_senders_not_their_newer_events() -> None:
    intake = EventIntake(size=100, max_age=10.0)
    for n in range(5):
        intake.offer(QueuedEvent(f"old{n}", "flooder", 0.1 * n))  # arrived before the person's
    intake.offer(QueuedEvent("music_play", "person", 1.0))
    intake.offer(QueuedEvent("new", "flooder", 2.0))
    first, _ = intake.take(2.0)
    assert first is not None and first.name == "old0"
    taken, dropped = intake.take(2.0)
    assert taken is not None and taken.name == "music_play"
    assert [(e.name, reason) for e, reason in dropped] == [
        (f"old{n}", DropReason.SUPERSEDED) for n in range(1, 5)
    ]
    assert names(intake, 2.0) == ["flooder:new"]


def test_events_older_than_max_age_are_dropped_when_their_turn_comes() -> None:
    intake = EventIntake(size=10, max_age=5.0)
    intake.offer(QueuedEvent("old", "a", 0.0))
    intake.offer(QueuedEvent("new", "a", 4.0))
    event, dropped = intake.take(6.0)
    assert dropped == [(QueuedEvent("old", "a", 0.0), DropReason.STALE)]
    assert event is not None and event.name == "new"
    assert intake.take(6.0) == (None, [])


def test_drops_are_one_line_for_the_first_then_one_summary_per_period() -> None:
    drops = DropCounter(period=10.0)
    assert drops.note(DropReason.OVERFLOW, "a") is True
    assert [drops.note(DropReason.OVERFLOW, s) for s in "abab"] == [False] * 4
    assert drops.note(DropReason.STALE, "c") is False
    assert (
        drops.summary()
        == "dropped 5 more event(s) in the last 10 s (4 overflow, 1 stale); sent by a 2, b 2, c 1"
    )
    assert drops.summary() is None  # nothing since: the burst is over, the next drop is logged again
    assert drops.note(DropReason.STALE, "c") is True
