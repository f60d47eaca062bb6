"""What the talking state answers to a person's request, and requests that wait for a yes or no (thesis 7.7).

Pure logic, no I/O. The navigation module hears a request (:class:`Request`: an intent about a
place), and the talking state carries out the :class:`Reply` that :func:`reply_to` gives for it:

* a command ("go to el6") is confirmed first: the robot asks "Shall I go to el6?" and sets off
  on yes; angry, it ignores the command (7.7);
* "where is el6?" offers to show the way, and sets off as a guide on yes (7.7, A.3);
* "what do you think of el6?" gets an opinion (7.7).

Any request can carry its own question (``Request.question``): the robot asks it first and
goes on with the request only on yes. That is the general "request awaiting yes or no": e.g.
"Did you mean the elevator?" when speech understanding is unsure of a place.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace

from cyborg.navigation.behaviour import ANGRY, Origin
from cyborg.navigation.keywords import Intent
from cyborg.navigation.models import Location, ResponseType

__all__ = ["Answer", "Reply", "ReplyKind", "Request", "after_answer", "reply_to"]


class Answer(enum.Enum):
    """What the person said to a yes-or-no question."""

    YES = "yes"
    NO = "no"
    SILENCE = "silence"
    """Nothing within the answer time."""


class ReplyKind(enum.Enum):
    SAY = "say"
    """Say one sentence; done."""
    ASK = "ask"
    """Say a question and wait for yes or no: yes carries out ``then``, no declines."""
    GO = "go"
    """Say a sentence ("At once.") and set off to the place (``origin`` says why)."""
    IGNORE = "ignore"
    """Say nothing (an angry robot and a command, 7.7)."""


@dataclass(frozen=True)
class Request:
    """A person's request about a place, as the navigation module heard it."""

    intent: Intent
    """NAVIGATION_COMMAND, NAVIGATION_INFORMATION or NAVIGATION_FEEDBACK."""
    place: Location
    question: ResponseType | None = None
    """Asked first; the request is carried out only on yes. None: the intent's own rule."""


@dataclass(frozen=True)
class Reply:
    kind: ReplyKind
    say: ResponseType | None
    place: Location
    then: Reply | None = None
    """What yes leads to (ASK only)."""
    origin: Origin | None = None
    """Why the robot sets off (GO only): COMMAND or GUIDE."""
    reason: str = ""


def reply_to(request: Request, emotion: str, *, on_map: bool = True, has_pose: bool = True) -> Reply:
    """The talking state's reply to ``request`` when the robot feels ``emotion``.

    ``on_map`` and ``has_pose`` say whether the place can be driven to on the loaded map; a
    command or a "where is" for one that cannot gets a sentence saying so instead of a question.
    """
    place = request.place
    if request.question is not None:
        then = reply_to(replace(request, question=None), emotion, on_map=on_map, has_pose=has_pose)
        return Reply(ReplyKind.ASK, request.question, place, then, reason=f"asks first about {place.name}")
    if request.intent is Intent.NAVIGATION_FEEDBACK:
        return Reply(ReplyKind.SAY, ResponseType.OPINION, place, reason=f"its opinion of {place.name}")
    if request.intent is Intent.NAVIGATION_COMMAND and emotion == ANGRY:
        return Reply(
            ReplyKind.IGNORE, None, place, reason=f"angry: ignores the command to go to {place.name}"
        )
    if not has_pose:
        return Reply(ReplyKind.SAY, ResponseType.NO_POSE, place, reason=f"{place.name} has no pose")
    if not on_map:
        return Reply(ReplyKind.SAY, ResponseType.NOT_ON_MAP, place, reason=f"{place.name} is not on the map")
    if request.intent is Intent.NAVIGATION_COMMAND:
        go = Reply(ReplyKind.GO, ResponseType.CONFIRM, place, origin=Origin.COMMAND, reason="confirmed")
        return Reply(ReplyKind.ASK, ResponseType.ASK_GO, place, go, reason=f"asks to confirm {place.name}")
    if request.intent is Intent.NAVIGATION_INFORMATION:
        guide = Reply(ReplyKind.GO, ResponseType.CONFIRM, place, origin=Origin.GUIDE, reason="guides")
        return Reply(ReplyKind.ASK, ResponseType.OFFER_GUIDE, place, guide, reason="offers to show the way")
    return Reply(ReplyKind.IGNORE, None, place, reason=f"{request.intent.value} is no request of talking")


def after_answer(reply: Reply, answer: Answer) -> Reply | None:
    """The next reply after ``answer`` to an ASK: ``then`` on yes, a DECLINED sentence on no, else None."""
    if answer is Answer.YES:
        return reply.then
    if answer is Answer.NO:
        return Reply(ReplyKind.SAY, ResponseType.DECLINED, reply.place, reason="declined")
    return None
