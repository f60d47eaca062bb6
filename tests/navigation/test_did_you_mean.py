"""Never misdirect: a place heard only roughly ("where is the a16" for the e16, el6's alias) is asked
about ("Did you mean the el6?") before the robot offers the way; yes goes on, no leaves it where it is."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from cyborg.transport.clock import VirtualClock
from tests.navigation.test_module import OFFER, Cyborg


@pytest.fixture
def cyborg(clock: VirtualClock, tmp_path: Path) -> Iterator[Cyborg]:
    robot = Cyborg(clock, tmp_path)
    yield robot
    robot.transport.shutdown()


ASKED = "Did you mean the el6?"


def test_a_roughly_heard_place_is_asked_about_then_offered_on_yes(
    clock: VirtualClock, cyborg: Cyborg
) -> None:
    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("where is the a16")
        await cyborg.until(lambda: ASKED in cyborg.sentences(), 5.0, "the question")
        assert cyborg.moved_since(0.0) == 0.0
        cyborg.hear("yes")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")
        cyborg.hear("yes")
        await cyborg.trip_done()

    clock.run(main())
    assert cyborg.at("el6")
    assert cyborg.sentences()[:2] == [ASKED, OFFER]


def test_a_roughly_heard_place_answered_no_stays(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("where is the a16")
        await cyborg.until(lambda: ASKED in cyborg.sentences(), 5.0, "the question")
        cyborg.hear("no")
        # Back where the question came from: the conversation a "where is" in idle starts (10.1).
        await cyborg.until(lambda: cyborg.state == "conversation", 30.0, "the conversation again")

    clock.run(main())
    assert OFFER not in cyborg.sentences() and cyborg.moved_since(0.0) == 0.0


def test_a_place_heard_clearly_is_offered_at_once(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("where is the e16")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")

    clock.run(main())
    assert ASKED not in cyborg.sentences()
