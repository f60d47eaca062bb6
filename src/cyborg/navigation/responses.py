"""The sentences of the navigation database (table ``responses``): what the robot says, by type and emotion.

One of the record stores that :class:`~cyborg.navigation.database.NavigationDatabase`
combines; it works on the connection :class:`~cyborg.storage.SQLiteFile` opened. A
sentence holds the placeholder ``LOCATION`` where the place's name goes; one with no
emotion fits every emotion and is the fallback when none fits the robot's.
"""

from __future__ import annotations

import logging
from dataclasses import replace

from cyborg.errors import DatabaseError
from cyborg.navigation.models import Response, ResponseType, checked_sentence, emotion_key
from cyborg.storage import SQLiteFile

log = logging.getLogger(__name__)


class ResponseStore(SQLiteFile):
    """Sentences by response type and emotion; every method commits before returning."""

    def list_responses(
        self, response_type: ResponseType | None = None, emotion: str | None = None
    ) -> list[Response]:
        """Stored responses, filtered by type and exact emotion if given (no fallback)."""
        rows = self._read("SELECT id, sentence, type, emotion FROM responses ORDER BY type, emotion, id")
        wanted = emotion_key(emotion) if emotion is not None else None
        found = []
        for row in rows:
            response = self._response_from_row(row)
            if response is None or (response_type is not None and response.type is not response_type):
                continue
            if wanted is None or response.emotion == wanted:
                found.append(response)
        return found

    def responses(self, response_type: ResponseType, emotion: str | None) -> list[Response]:
        """Sentences of ``response_type`` for ``emotion``; those for any emotion if there are none."""
        key = emotion_key(emotion)
        of_type = self.list_responses(response_type)
        specific = [r for r in of_type if key is not None and r.emotion == key]
        return specific or [r for r in of_type if r.emotion is None]

    def add_response(self, response: Response) -> Response:
        response = self._checked_response(response, own_id=None)
        with self._writing("add a response") as conn:
            cursor = conn.execute(
                "INSERT INTO responses (sentence, type, emotion) VALUES (?, ?, ?)",
                (response.sentence, response.type.value, response.emotion),
            )
        return replace(response, id=cursor.lastrowid)

    def update_response(self, response_id: int, response: Response) -> Response:
        self._get_response(response_id)
        response = replace(self._checked_response(response, own_id=response_id), id=response_id)
        with self._writing(f"update response {response_id}") as conn:
            conn.execute(
                "UPDATE responses SET sentence = ?, type = ?, emotion = ? WHERE id = ?",
                (response.sentence, response.type.value, response.emotion, response_id),
            )
        return response

    def remove_response(self, response_id: int) -> Response:
        response = self._get_response(response_id)
        with self._writing(f"remove response {response_id}") as conn:
            conn.execute("DELETE FROM responses WHERE id = ?", (response_id,))
        return response

    def _get_response(self, response_id: int) -> Response:
        found = [r for r in self.list_responses() if r.id == response_id]
        if not found:
            raise DatabaseError(
                f"no response with id {response_id}; list them with `cyborg db responses list`"
            )
        return found[0]

    def _checked_response(self, response: Response, own_id: int | None) -> Response:
        checked = checked_sentence(response)
        for other in self.list_responses(checked.type):
            if other.id != own_id and (other.sentence, other.emotion) == (checked.sentence, checked.emotion):
                raise DatabaseError(
                    f"response {checked.sentence!r} exists already (id {other.id}); nothing to add"
                )
        return checked

    def _response_from_row(self, row: tuple[object, ...]) -> Response | None:
        response_id, sentence, kind, emotion = row
        try:
            response_type = ResponseType(str(kind))
        except ValueError:
            log.warning("skipping response %s in %s: unknown type %r", response_id, self.path, kind)
            return None
        try:
            key = None if emotion is None else emotion_key(str(emotion))
        except DatabaseError:
            log.warning(
                "response %s in %s has emotion %r, no name; it fits any emotion",
                response_id,
                self.path,
                emotion,
            )
            key = None
        return Response(str(sentence), response_type, key, int(str(response_id)))
