"""Never misdirect: a place heard only roughly ("where is the a16" for the e16, el6's alias), or one
the ears doubt (``/cyborg_speech/unsure``), is asked about ("Did you mean the el6?") before the robot
offers the way; yes goes on, no leaves it where it is."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from cyborg.transport import topics
from cyborg.transport.clock import VirtualClock
from cyborg.transport.messages import String
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


def _unsure(cyborg: Cyborg, text: str, place: str) -> None:
    """What the ears send for a request whose place they doubt: not on /text_from_speech."""
    publisher = cyborg.transport.node("test_ears").publisher(topics.SPEECH_UNSURE, String)
    publisher.publish(String(data=json.dumps({"text": text, "place": place, "confidence": 0.4})))


def test_a_place_the_ears_doubt_is_asked_about_in_idle_and_nothing_moves_on_no(
    clock: VirtualClock, cyborg: Cyborg
) -> None:
    """ "where is the gym" heard as "where is the entrance", the ears unsure of the place: the robot
    asks rather than offering the way to a place nobody named; no leaves it where it is."""

    async def main() -> None:
        await cyborg.settle()
        _unsure(cyborg, "where is the entrance", "entrance")
        await cyborg.until(lambda: "Did you mean the entrance?" in cyborg.sentences(), 10.0, "the question")
        cyborg.hear("no")
        await cyborg.until(lambda: cyborg.state == "conversation", 30.0, "the conversation again")

    clock.run(main())
    assert cyborg.sentences()[0] == "Did you mean the entrance?"
    assert OFFER not in cyborg.sentences() and cyborg.moved_since(0.0) == 0.0


def test_a_place_the_ears_doubt_is_asked_about_then_offered_on_yes(
    clock: VirtualClock, cyborg: Cyborg
) -> None:
    async def main() -> None:
        await cyborg.settle()
        _unsure(cyborg, "where is el6", "el6")
        await cyborg.until(lambda: ASKED in cyborg.sentences(), 10.0, "the question")
        cyborg.hear("yes")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")
        cyborg.hear("yes")
        await cyborg.trip_done()

    clock.run(main())
    assert cyborg.at("el6")
    assert cyborg.sentences()[:2] == [ASKED, OFFER]


def test_a_doubted_command_is_confirmed_by_its_own_question_naming_the_place(
    clock: VirtualClock, cyborg: Cyborg
) -> None:
    async def main() -> None:
        await cyborg.settle()
        _unsure(cyborg, "go to the cafeteria", "cafeteria")
        await cyborg.until(lambda: bool(cyborg.sentences()), 10.0, "a question")
        cyborg.hear("no")
        await cyborg.until(lambda: len(cyborg.sentences()) >= 2, 10.0, "the decline")

    clock.run(main())
    assert cyborg.sentences()[0] == "Shall I go to the cafeteria?"
    assert cyborg.moved_since(0.0) == 0.0


def test_a_malformed_unsure_message_is_left_out(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle()
        publisher = cyborg.transport.node("stranger").publisher(topics.SPEECH_UNSURE, String)
        for data in ("where is el6", json.dumps({"text": "where is el6"}), json.dumps(["el6"])):
            publisher.publish(String(data=data))
        await clock.sleep(5.0)

    clock.run(main())
    assert cyborg.sentences() == []
