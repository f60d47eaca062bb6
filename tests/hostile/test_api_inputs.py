"""Issue 12, items 5 and 6 at the HTTP API: hostile bodies are answered 400 with the problem, never
500, and an emotion the robot does not know is refused instead of answered "sent"."""

from __future__ import annotations

from typing import Any

from aiohttp import ClientSession

from cyborg.emotion.model import EmotionSettings
from cyborg.limits import MAX_TEXT_LENGTH
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.messages import String
from cyborg.web.api import RobotAPI
from tests.support.api import real_time, served


def post_all(requests: list[tuple[str, bytes]]) -> tuple[list[tuple[int, Any]], dict[str, list[str]]]:
    """POST each (path, body) to a fresh API; return (status, JSON) answers and what reached each topic."""
    settings = EmotionSettings()
    published: dict[str, list[str]] = {topics.SET_EMOTIONAL_STATE: [], topics.TEXT_FROM_SPEECH: []}
    with real_time() as (clock, transport):
        listener = transport.node("listener")
        for topic, seen in published.items():

            def keep(message: String, info: MessageInfo, seen: list[str] = seen) -> None:
                seen.append(message.data)

            listener.subscribe(topic, String, keep)

        async def main() -> list[tuple[int, Any]]:
            api = RobotAPI(
                transport.node("cyborg_api"),
                emotions=dict(settings.prototypes),
                emotion_aliases=settings.usable_aliases(),
            )
            answers = []
            async with served(api) as url, ClientSession() as session:
                for path, body in requests:
                    headers = {"Content-Type": "application/json"}
                    async with session.post(url + path, data=body, headers=headers) as response:
                        answers.append((response.status, await response.json()))
            return answers

        return clock.run(main()), published


def test_hostile_bodies_are_answered_400_naming_the_problem() -> None:
    answers, published = post_all(
        [
            ("/api/emotion/values", b'{"pleasure": ' + b"9" * 5000 + b', "arousal": 0, "dominance": 0}'),
            ("/api/event", b"[" * 20_000 + b"]" * 20_000),  # nested deeper than Python recurses
            ("/api/say", b'{"text": "' + b"la " * MAX_TEXT_LENGTH + b'"}'),
            ("/api/event", b'\xef\xbb\xbf{"name": "music_play"}'),  # a UTF-8 BOM (RFC 8259: not sent)
            ("/api/event", '{"name": "music_play"}'.encode("utf-16")),  # JSON travels as UTF-8
        ]
    )
    statuses = [status for status, _ in answers]
    assert statuses == [400, 400, 400, 400, 400], answers
    assert all("not usable JSON" in answer["error"] for _, answer in answers[3:]), answers
    assert "not usable JSON" in answers[0][1]["error"] and "not usable JSON" in answers[1][1]["error"]
    assert f"over the limit of {MAX_TEXT_LENGTH}" in answers[2][1]["error"]
    assert published[topics.TEXT_FROM_SPEECH] == []


def test_an_unknown_emotion_is_refused_and_a_known_name_or_alias_is_sent() -> None:
    answers, published = post_all(
        [
            ("/api/emotion/set", b'{"name": "joyful"}'),
            ("/api/emotion/set", b'{"name": "elated"}'),
            ("/api/emotion/set", b'{"name": "Happy"}'),
        ]
    )
    assert [status for status, _ in answers] == [400, 200, 200], answers
    assert "unknown emotion 'joyful'" in answers[0][1]["error"] and "elated" in answers[0][1]["error"]
    assert published[topics.SET_EMOTIONAL_STATE] == ["elated", "Happy"]
