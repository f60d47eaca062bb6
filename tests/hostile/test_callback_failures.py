"""Review 11.6: a module callback that raises on every sentence logged a full traceback each time, so
a flood of sentences was a flood of tracebacks. Now: the traceback once, then a counted line at most
every 10 s (the callback still runs every time, and every failure is counted)."""

from __future__ import annotations

import logging

import pytest

from cyborg.transport._callbacks import REPEAT_PERIOD, CallbackRunner


def test_a_callback_that_keeps_failing_is_logged_once_then_counted(caplog: pytest.LogCaptureFixture) -> None:
    now = [0.0]
    errors: list[int] = []
    runner = CallbackRunner(logging.getLogger("hostile"), lambda: errors.append(1), now=lambda: now[0])

    def heard(text: str) -> None:
        raise ValueError(f"cannot parse {text!r}")

    with caplog.at_level(logging.ERROR, logger="hostile"):
        for i in range(500):
            now[0] = i * 0.01  # 500 sentences in 5 s
            runner(heard, f"sentence {i}")
        now[0] = 5.0 + REPEAT_PERIOD
        runner(heard, "one more")

    assert len(errors) == 501
    assert len(caplog.records) == 2, [r.getMessage() for r in caplog.records]
    first, later = caplog.records
    assert first.exc_info is not None and "heard failed" in first.getMessage()
    assert later.exc_info is None and "failed again (500 times" in later.getMessage()
    assert "cannot parse 'one more'" in later.getMessage()
