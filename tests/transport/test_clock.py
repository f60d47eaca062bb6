"""Periodic work on the clock (``clock.every``): it survives a failing tick and logs each episode once;
closing the clock runs what was tied to it."""

from __future__ import annotations

import logging

import pytest

from cyborg.errors import DatabaseError
from cyborg.transport.clock import VirtualClock


class Flaky:
    """A tick that fails while ``broken`` is set; records the clock time of every call."""

    def __init__(self, clock: VirtualClock, error: Exception) -> None:
        self.clock = clock
        self.error = error
        self.broken = False
        self.calls: list[float] = []

    def __call__(self) -> None:
        self.calls.append(round(self.clock.monotonic(), 6))
        if self.broken:
            raise self.error


def messages(caplog: pytest.LogCaptureFixture, level: int = logging.WARNING) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= level]


def test_a_failing_tick_keeps_the_work_running_logs_once_and_logs_the_recovery(
    clock: VirtualClock, caplog: pytest.LogCaptureFixture
) -> None:
    tick = Flaky(clock, RuntimeError("the sensor went away"))
    caplog.set_level(logging.DEBUG)
    periodic = clock.every(2.0, tick, name="the sensor poll")

    clock.run(clock.sleep(4.5))
    assert tick.calls == [2.0, 4.0]
    assert messages(caplog) == []

    tick.broken = True
    clock.run(clock.sleep(10.0))  # five failing ticks
    assert tick.calls == [2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0]
    warnings = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1
    assert "the sensor poll failed: RuntimeError: the sensor went away" in warnings[0].getMessage()
    assert warnings[0].exc_info is not None  # an unexpected error: its traceback, once
    assert periodic.failures == 5

    tick.broken = False
    clock.run(clock.sleep(4.0))
    assert tick.calls[-2:] == [16.0, 18.0]
    assert messages(caplog)[1:] == [
        "the sensor poll recovered: it works again after 5 failed ticks (RuntimeError: the sensor went away)"
    ]
    assert periodic.failures == 0

    tick.broken = True  # a second episode is logged again, once
    clock.run(clock.sleep(6.0))
    assert len(messages(caplog)) == 3
    assert "the sensor poll failed" in messages(caplog)[2]


def test_a_known_error_is_logged_without_a_traceback(
    clock: VirtualClock, caplog: pytest.LogCaptureFixture
) -> None:
    tick = Flaky(clock, DatabaseError("could not save x: disk full; fix: free some space"))
    tick.broken = True
    clock.every(1.0, tick, name="saving")
    clock.run(clock.sleep(5.5))
    [warning] = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert warning.exc_info is None
    assert (
        "saving failed: DatabaseError: could not save x: disk full; fix: free some space"
        in warning.getMessage()
    )


def test_cancel_stops_the_work_also_from_inside_its_tick(clock: VirtualClock) -> None:
    tick = Flaky(clock, RuntimeError())
    periodic = clock.every(1.0, tick, name="work")
    clock.run(clock.sleep(2.5))
    periodic.cancel()
    clock.run(clock.sleep(5.0))
    assert tick.calls == [1.0, 2.0]
    assert periodic.cancelled

    calls: list[float] = []

    def once() -> None:
        calls.append(clock.monotonic())
        itself.cancel()

    itself = clock.every(1.0, once, name="once")
    clock.run(clock.sleep(5.0))
    assert len(calls) == 1


@pytest.mark.parametrize("period", [0.0, -1.0, float("nan"), float("inf")])
def test_a_period_that_is_not_a_positive_number_is_refused(clock: VirtualClock, period: float) -> None:
    with pytest.raises(ValueError, match="the period of work must be a positive number of seconds"):
        clock.every(period, lambda: None, name="work")


def test_closing_the_clock_runs_its_close_callbacks_once_after_its_tasks_end(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """What lives as long as the loop (the base's search worker) is stopped with it, even when one
    of those callbacks fails."""
    clock = VirtualClock()
    seen: list[str] = []

    async def forever() -> None:
        try:
            await clock.sleep(1e9)
        finally:
            seen.append("task ended")

    def broken() -> None:
        raise RuntimeError("cannot stop")

    clock.on_close(lambda: seen.append("first"))
    clock.on_close(broken)
    clock.on_close(lambda: seen.append("last"))
    clock.loop.create_task(forever())
    clock.run(clock.sleep(1.0))
    with caplog.at_level(logging.ERROR):
        clock.close()
        clock.close()
    assert seen == ["task ended", "first", "last"]
    assert [r.getMessage() for r in caplog.records if "closing the clock" in r.getMessage()] != []
