"""What a subscriber believes of the graph (cyborg.transport.guards): a sender, a length."""

from __future__ import annotations

import logging

import pytest

from cyborg.limits import MAX_TEXT_LENGTH
from cyborg.transport.guards import OnlyFrom, TextLimit


def test_only_the_named_node_is_believed_and_each_stranger_is_logged_once(
    caplog: pytest.LogCaptureFixture,
) -> None:
    guard = OnlyFrom("cyborg_controller", "/cyborg_controller/state_change", "state changes")
    with caplog.at_level(logging.WARNING):
        assert guard.accepts("/cyborg_controller") and guard.accepts("cyborg_controller")
        assert [guard.accepts("stranger") for _ in range(1000)] == [False] * 1000
    assert guard.ignored["stranger"] == 1000
    assert len(caplog.records) == 1 and "from stranger" in caplog.records[0].getMessage()


def test_a_text_over_the_apis_limit_is_refused_and_logged_once_without_the_text(
    caplog: pytest.LogCaptureFixture,
) -> None:
    limit = TextLimit("/text_from_speech")
    with caplog.at_level(logging.WARNING):
        assert limit.accepts("x" * MAX_TEXT_LENGTH, "api")
        assert not limit.accepts("y" * 1_000_000, "stranger")
        assert not limit.accepts("y" * 3_000, "stranger")
    assert limit.refused["stranger"] == 2
    assert len(caplog.records) == 1 and len(caplog.records[0].getMessage()) < 400
