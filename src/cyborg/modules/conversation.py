"""Conversation and question modules of the thesis's test system (10.1).

The conversation module listens to speech-to-text: a greeting asks the
controller for the ``conversation`` state (event ``conversation_interest``).
While in conversation it waits; the motivator picks one of the question
states (joke, weather, selfie, follower, Simon says), each served by its own
question module, which asks its question, waits for an answer and succeeds. A
question left unanswered cools the robot down (less arousal: unconcerned, as in
thesis 10.2.4); an answer pleases it. The conversation ends (succeeded) after a
quiet spell. Registered as the module kinds ``conversation`` and ``question``.
"""

from __future__ import annotations

import re

from pydantic import Field

from cyborg.modules.behaviour import BehaviourModule, GoalContext
from cyborg.modules.kind import BuildContext, ModuleKind, ModuleSettings
from cyborg.transport.base import MessageInfo, Node

GREETINGS = frozenset({"hello", "hi", "hey", "hallo", "hei", "greetings", "howdy", "yo", "hiya", "heya"})
GREETING_PHRASES = (
    "good morning",
    "good afternoon",
    "good evening",
    "good day",
    "nice to meet you",
    "pleased to meet you",
    "whats up",
)
"""Not "how are you": primed with it, Whisper hears "how old are you" as it."""
CONVERSATION_ACTION = "cyborg_conversation/conversation"
CONVERSATION_INTEREST = "conversation_interest"


def is_greeting(text: str) -> bool:
    """True when ``text`` greets the robot ("Hello!", "hi there", "good morning Cyborg", "nice to meet you").

    The greeting comes first ("well, hello"): "how old are you" and "I said hello to him" are none.
    """
    words = re.findall(r"[a-zæøå]+", text.lower().replace("'", "").replace("\u2019", ""))
    opening = words[1:] if words[:1] in (["well"], ["oh"], ["and"]) else words
    said = " ".join(opening)
    return bool(opening) and (
        opening[0] in GREETINGS or any(f"{said} ".startswith(f"{p} ") for p in GREETING_PHRASES)
    )


class ConversationModule(BehaviourModule):
    """Asks for the conversation state on a greeting; stays until ``quiet_seconds`` pass without speech."""

    def __init__(self, node: Node, *, quiet_seconds: float = 90.0, action: str = CONVERSATION_ACTION) -> None:
        super().__init__(node)
        self.quiet_seconds = quiet_seconds
        self.last_heard = node.clock.monotonic()
        self.in_conversation = False
        self.serve(action, self.converse)
        self.on_speech_text(self._on_text)

    def _on_text(self, text: str, info: MessageInfo) -> None:
        self.last_heard = self.node.clock.monotonic()
        if is_greeting(text) and not self.in_conversation:
            self.publish_event(CONVERSATION_INTEREST)

    async def converse(self, ctx: GoalContext) -> None:
        self.in_conversation = True
        try:
            if ctx.event == CONVERSATION_INTEREST:
                self.last_heard = self.node.clock.monotonic()
            while True:
                remaining = self.last_heard + self.quiet_seconds - self.node.clock.monotonic()
                if remaining <= 0:
                    return  # the person left: succeeded
                await ctx.sleep(remaining)
        finally:
            self.in_conversation = False


UNANSWERED_FEEDBACK = (-0.01, -0.04, 0.01)
"""PAD change when nobody answers a question: the robot cools down towards unconcerned."""
ANSWERED_FEEDBACK = (0.03, 0.03, 0.0)
"""PAD change when someone answers."""


class QuestionModule(BehaviourModule):
    """Asks one question through speech, gives the person time to answer, and succeeds.

    Whatever speech-to-text hears in that time counts as an answer (``answered_feedback``);
    silence sends ``unanswered_feedback``.
    """

    def __init__(
        self,
        node: Node,
        *,
        action: str,
        question: str,
        answer_seconds: float = 6.0,
        unanswered_feedback: tuple[float, float, float] = UNANSWERED_FEEDBACK,
        answered_feedback: tuple[float, float, float] = ANSWERED_FEEDBACK,
    ) -> None:
        super().__init__(node)
        self.question = question
        self.answer_seconds = answer_seconds
        self.unanswered_feedback = unanswered_feedback
        self.answered_feedback = answered_feedback
        self._asked_at: float | None = None
        self._answered = False
        self.serve(action, self.ask)
        self.on_speech_text(self._on_text)

    def _on_text(self, text: str, info: MessageInfo) -> None:
        if self._asked_at is not None:
            self._answered = True

    async def ask(self, ctx: GoalContext) -> None:
        self._answered = False
        self._asked_at = self.node.clock.monotonic()
        try:
            self.say(self.question)
            await ctx.sleep(self.answer_seconds)
        finally:
            self._asked_at = None
        self.send_emotion(*(self.answered_feedback if self._answered else self.unanswered_feedback))


class ConversationSettings(ModuleSettings):
    """Asks for the conversation state when someone greets the robot; ends after a quiet spell."""

    action: str = Field(CONVERSATION_ACTION, description="action server of the conversation state")
    quiet_seconds: float = Field(90.0, gt=0, description="seconds without speech that end the conversation")

    def listens_for(self) -> tuple[str, ...]:
        """Greetings: a sentence starting with one of them asks for the conversation state."""
        return (*sorted(GREETINGS), *GREETING_PHRASES)

    def publishes(self) -> tuple[str, ...]:
        return (CONVERSATION_INTEREST,)


class QuestionSettings(ModuleSettings):
    """Asks one question, waits for an answer, and tells the emotion system how it went."""

    action: str = Field(description="action server of the question's state")
    question: str = Field(min_length=1, description="what the robot asks")
    answer_seconds: float = Field(6.0, ge=0, description="seconds it waits for an answer")
    unanswered_feedback: tuple[float, float, float] = Field(
        UNANSWERED_FEEDBACK, description="PAD change when nobody answers"
    )
    answered_feedback: tuple[float, float, float] = Field(
        ANSWERED_FEEDBACK, description="PAD change when someone answers"
    )

    def speaks_in(self) -> tuple[str, ...]:
        return (self.action,)


def _conversation(node: Node, settings: ConversationSettings, context: BuildContext) -> ConversationModule:
    return ConversationModule(node, quiet_seconds=settings.quiet_seconds, action=settings.action)


def _question(node: Node, settings: QuestionSettings, context: BuildContext) -> QuestionModule:
    return QuestionModule(node, **settings.model_dump())


CONVERSATION_KIND = ModuleKind(ConversationSettings, _conversation)
QUESTION_KIND = ModuleKind(QuestionSettings, _question)
