"""Conversation and question modules of the thesis's test system (10.1).

The conversation module listens to speech-to-text: any text asks the controller
for the ``conversation`` state (event ``conversation_interest``, thesis 10.1). A
greeting asks at once; other text after ``claim_seconds``, and only if the
robot's state has not changed meanwhile: another module acted on it ("go to el6"
is a command for the navigation module, not small talk). An ask the controller
drops (the active state has no such transition) is made once more at the next
state change within ``patience`` seconds if it was a greeting: "hello" to a
wandering robot is taken once the wander has stopped to listen.
While in conversation it waits; the motivator picks one of the question
states (joke, weather, selfie, follower, Simon says), each served by its own
question module, which asks its question, waits for an answer and succeeds. A
question left unanswered cools the robot down (less arousal: unconcerned, as in
thesis 10.2.4); an answer pleases it. The conversation ends (succeeded) after a
quiet spell. Registered as the module kinds ``conversation`` and ``question``.
"""

from __future__ import annotations

import re
from dataclasses import asdict, dataclass

from cyborg.modules.behaviour import BehaviourModule, GoalContext
from cyborg.modules.kind import BuildContext, KindSettings, ModuleKind, setting
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.messages import SystemState

GREETINGS = frozenset(
    {"hello", "hi", "hey", "hallo", "hei", "greetings", "howdy", "yo", "hiya", "heya", "morning", "evening"}
)
GREETING_PHRASES = (
    "good morning",
    "good afternoon",
    "good evening",
    "good day",
    "nice to meet you",
    "pleased to meet you",
    "nice to see you",
    "good to see you",
    "great to see you",
    "whats up",
    "how are you",
    "how are you doing",
    "how is it going",
    "hows it going",
    "how do you do",
)
"""Whisper is not primed with these (its prompt leaves greetings out): primed with "how are you",
it heard "how old are you" as it (docs/benchmarks-history.md, issue 34)."""
CONVERSATION_ACTION = "cyborg_conversation/conversation"
CONVERSATION_INTEREST = "conversation_interest"
CLAIM_SECONDS = 1.0
"""Seconds other text waits for another module to act on it before it starts a conversation."""
PATIENCE = 10.0
"""Seconds an ask the controller dropped is made again at each state change."""


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
    """Asks for the conversation state on any text (10.1); stays until ``quiet_seconds`` pass without speech.

    Once in conversation, the robot counts as conversing until it is back in its initial state
    (the person's questions and the robot's own, asked in other states, are part of it).
    """

    def __init__(
        self,
        node: Node,
        *,
        quiet_seconds: float = 90.0,
        action: str = CONVERSATION_ACTION,
        claim_seconds: float = CLAIM_SECONDS,
        patience: float = PATIENCE,
    ) -> None:
        super().__init__(node)
        self.quiet_seconds = quiet_seconds
        self.claim_seconds = claim_seconds
        self.patience = patience
        self.last_heard = node.clock.monotonic()
        self.in_conversation = False
        self.conversing = False
        self.state_changes = 0
        self._initial_state: str | None = None
        self._state_name: str | None = None
        self._asking_until = -1.0
        self.serve(action, self.converse)
        self.on_speech_text(self._on_text)
        self.on_unsure_speech(lambda text, place, info: self._on_text(text, info))  # spoken to, all the same
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_state_change, queue_size=100)

    def _on_state_change(self, message: SystemState, info: MessageInfo) -> None:
        self.state_changes += 1
        if self._initial_state is None and not message.from_system_state:
            self._initial_state = message.to_system_state
        if message.to_system_state == self._state_name:
            self.conversing = True
        elif message.to_system_state == self._initial_state:
            self.conversing = False
        now = self.node.clock.monotonic()
        if message.event == CONVERSATION_INTEREST or now > self._asking_until:
            self._asking_until = -1.0
        elif not self.conversing:
            self.publish_event(CONVERSATION_INTEREST)  # dropped before; the robot has moved on

    def _on_text(self, text: str, info: MessageInfo) -> None:
        self.last_heard = self.node.clock.monotonic()
        if self.in_conversation or self.conversing:
            return
        if is_greeting(text):
            self._ask(again=True)
            return
        changes = self.state_changes
        self.node.clock.call_later(self.claim_seconds, lambda: self._ask_unless_claimed(changes))

    def _ask_unless_claimed(self, changes: int) -> None:
        if self.state_changes == changes and not (self.in_conversation or self.conversing):
            self._ask(again=False)

    def _ask(self, *, again: bool) -> None:
        """Ask for the conversation; ``again``: once more at each state change within ``patience``."""
        self._asking_until = self.node.clock.monotonic() + self.patience if again else -1.0
        self.publish_event(CONVERSATION_INTEREST)

    async def converse(self, ctx: GoalContext) -> None:
        self.in_conversation = True
        self._state_name = ctx.state
        self.conversing = True
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


@dataclass(frozen=True, kw_only=True)
class ConversationSettings(KindSettings):
    """Asks for the conversation state when someone speaks to the robot (10.1); ends after a quiet spell."""

    action: str = setting(CONVERSATION_ACTION, description="action server of the conversation state")
    quiet_seconds: float = setting(90.0, gt=0, description="seconds without speech that end the conversation")

    def listens_for(self) -> tuple[str, ...]:
        """Greetings ask for the conversation state at once; any other text does if no module acts on it."""
        return (*sorted(GREETINGS), *GREETING_PHRASES)

    def publishes(self) -> tuple[str, ...]:
        return (CONVERSATION_INTEREST,)


@dataclass(frozen=True, kw_only=True)
class QuestionSettings(KindSettings):
    """Asks one question, waits for an answer, and tells the emotion system how it went."""

    action: str = setting(description="action server of the question's state")
    question: str = setting(min_length=1, description="what the robot asks")
    answer_seconds: float = setting(6.0, ge=0, description="seconds it waits for an answer")
    unanswered_feedback: tuple[float, float, float] = setting(
        UNANSWERED_FEEDBACK, description="PAD change when nobody answers"
    )
    answered_feedback: tuple[float, float, float] = setting(
        ANSWERED_FEEDBACK, description="PAD change when someone answers"
    )

    def speaks_in(self) -> tuple[str, ...]:
        return (self.action,)


def _conversation(node: Node, settings: ConversationSettings, context: BuildContext) -> ConversationModule:
    return ConversationModule(node, quiet_seconds=settings.quiet_seconds, action=settings.action)


def _question(node: Node, settings: QuestionSettings, context: BuildContext) -> QuestionModule:
    return QuestionModule(node, **asdict(settings))


CONVERSATION_KIND = ModuleKind(ConversationSettings, _conversation)
QUESTION_KIND = ModuleKind(QuestionSettings, _question)
