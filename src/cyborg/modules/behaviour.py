"""The module-side helper: a behaviour module's action server in a few lines.

A module writes one ``async def execute(ctx)`` per state it serves. The helper
runs it when the controller sends a goal, cancels it when the controller
preempts (the coroutine gets ``asyncio.CancelledError`` at its next ``await``,
so it stops at once; use ``try/finally`` to clean up) and reports the outcome:

* returning normally (or ``return Outcome.SUCCEEDED``) -> SUCCEEDED, the event ``succeeded``;
* ``raise Abort("why")`` or ``return Outcome.ABORTED`` -> ABORTED, the event ``aborted``;
* an unexpected exception -> logged, ABORTED (the controller carries on).

Example::

    class Music(BehaviourModule):
        def __init__(self, node):
            super().__init__(node)
            self.serve("cyborg_music/play", self.play)

        async def play(self, ctx):
            self.say("Here is a song.")
            await ctx.sleep(30)
"""

from __future__ import annotations

import asyncio
import enum
import json
import logging
from collections.abc import Awaitable, Callable
from datetime import datetime
from typing import Any

from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, MessageInfo, Node, ServerGoalHandle, normalize_node_name
from cyborg.transport.guards import TextLimit
from cyborg.transport.messages import (
    EmotionalFeedback,
    EmotionalState,
    StateMachineAction,
    StateMachineFeedback,
    StateMachineGoal,
    StateMachineResult,
    String,
)

log = logging.getLogger(__name__)
HEARTBEAT_SECONDS = 5.0  # a running goal sends feedback this often (the dashboard shows its age)

_GoalHandle = ServerGoalHandle[StateMachineGoal, StateMachineResult, StateMachineFeedback]


class Outcome(enum.Enum):
    """How a goal ends when ``execute`` returns it: the controller takes the event of that name."""

    SUCCEEDED = "succeeded"
    ABORTED = "aborted"


class Abort(Exception):
    """Raise inside ``execute`` to end the goal ABORTED with a reason.

    Deliberately not a CyborgError: it is a control-flow signal, not an error of the package.
    The state's action server catches it and reports the goal aborted (the controller then takes
    the state's ``aborted`` transition); an ``except CyborgError`` in a module's own code must not
    swallow it.
    """


class GoalContext:
    """What ``execute`` gets: the goal, the clock and feedback helpers."""

    def __init__(self, module: BehaviourModule, handle: _GoalHandle) -> None:
        self._module = module
        self._handle = handle
        self.goal: StateMachineGoal = handle.goal

    @property
    def event(self) -> str:
        """The event that led the controller to this state."""
        return self.goal.event

    @property
    def previous_state(self) -> str:
        """The state the controller left for this one."""
        return self.goal.previous_state

    @property
    def state(self) -> str:
        """The state this goal serves (one action server may serve several)."""
        return self.goal.current_state

    @property
    def preempt_requested(self) -> bool:
        """True once the controller asked to stop (modules that ignore cancel can poll it)."""
        return self._handle.cancel_requested

    def now(self) -> datetime:
        """The robot's current date-time, an aware UTC datetime: virtual in simulations, scenarios
        and the ModuleHarness. Convert it for people, e.g. ``ctx.now().astimezone(ZoneInfo("Europe/Oslo"))``."""
        return self._module.now()

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` on the robot's clock (virtual in simulations); preemption ends it at once."""
        await self._module.node.clock.sleep(seconds)

    async def wait_forever(self) -> None:
        """Stay in control until the controller preempts."""
        await asyncio.get_running_loop().create_future()

    def feedback(self, status: str, message: str = "") -> None:
        """Action feedback to the controller (the dashboard shows when a module last sent some)."""
        self._handle.publish_feedback(StateMachineFeedback(status=status, message=message))


Execute = Callable[[GoalContext], Awaitable[Outcome | None]]


class StateServer:
    """One action server with SimpleActionServer policy: one goal at a time, a new goal preempts."""

    def __init__(
        self, module: BehaviourModule, name: str, execute: Execute, *, honour_cancel: bool = True
    ) -> None:
        self.module = module
        self.name = name
        self._execute = execute
        self.honour_cancel = honour_cancel
        self._current: tuple[_GoalHandle, asyncio.Task[Any]] | None = None
        self.goals_received = 0
        self.server = module.node.action_server(name, StateMachineAction, self._on_goal, self._on_cancel)

    @property
    def active(self) -> bool:
        return self._current is not None and not self._current[0].status.is_terminal

    def close(self) -> None:
        """Stop the goal that runs (it ends as preempted) and withdraw the action server."""
        if self._current is not None and not self._current[1].done():
            self._current[1].cancel()
        self.server.shutdown()

    def _on_goal(self, handle: _GoalHandle) -> None:
        self.goals_received += 1
        if self._current is not None:
            old_handle, old_task = self._current
            if not old_handle.status.is_terminal:
                old_task.cancel()
        handle.accept()
        task = self.module.node.clock.loop.create_task(self._run(handle), name=f"{self.name} goal")
        # A task cancelled before it first runs never enters _run: acknowledge it here.
        task.add_done_callback(lambda t: self._acknowledge_if_cancelled(t, handle))
        self._current = (handle, task)

    @staticmethod
    def _acknowledge_if_cancelled(task: asyncio.Task[Any], handle: _GoalHandle) -> None:
        if task.cancelled() and not handle.status.is_terminal:
            handle.canceled(StateMachineResult(status="preempted"))

    def _on_cancel(self, handle: _GoalHandle) -> None:
        if not self.honour_cancel:
            log.info("%s ignores the cancel request (configured to)", self.name)
            return
        if self._current is not None and self._current[0] is handle:
            self._current[1].cancel()
        elif not handle.status.is_terminal:
            handle.canceled()

    async def _heartbeat(self, ctx: GoalContext, handle: _GoalHandle) -> None:
        """Feedback while the goal runs, so the controller and the dashboard see the module alive."""
        while not handle.status.is_terminal:
            ctx.feedback("active")
            await ctx.sleep(HEARTBEAT_SECONDS)

    async def _run(self, handle: _GoalHandle) -> None:
        ctx = GoalContext(self.module, handle)
        heartbeat = self.module.node.clock.loop.create_task(
            self._heartbeat(ctx, handle), name=f"{self.name} heartbeat"
        )
        try:
            await self._execute_goal(ctx, handle)
        finally:
            heartbeat.cancel()

    async def _execute_goal(self, ctx: GoalContext, handle: _GoalHandle) -> None:
        try:
            outcome = await self._execute(ctx)
        except asyncio.CancelledError:
            if not handle.status.is_terminal:
                handle.canceled(StateMachineResult(status="preempted"))
            return
        except Abort as exc:
            handle.abort(StateMachineResult(status="aborted", message=str(exc)), str(exc))
            return
        except Exception as exc:
            log.exception("%s crashed; reporting ABORTED to the controller", self.name)
            self.module._report_crash(self.name, exc)
            handle.abort(StateMachineResult(status="aborted", message=f"crashed: {exc!r}"), repr(exc))
            return
        if handle.status.is_terminal:
            return
        if outcome is Outcome.ABORTED:
            handle.abort(StateMachineResult(status="aborted"))
        elif handle.status in (GoalStatus.ACTIVE, GoalStatus.PREEMPTING):
            handle.succeed(StateMachineResult(status="succeeded"))


class BehaviourModule:
    """Base class for behaviour modules: serve states, send events, feedback and speech.

    ``emotion`` is the robot's current emotion (from ``/cyborg_controller/emotional_state``).
    """

    def __init__(self, node: Node) -> None:
        self.node = node
        self.emotion = "neutral"
        self.servers: dict[str, StateServer] = {}
        self._emotion_listeners: list[Callable[[str, str], None]] = []
        self._events = node.publisher(topics.REGISTER_EVENT, String)
        self._feedback = node.publisher(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback)
        self._speech = node.publisher(
            topics.TEXT_TO_SPEECH, String
        )  # early, so over ROS the first line is heard
        self._crashes = node.publisher(topics.MODULE_CRASHED, String)
        self._heard_limit = TextLimit(topics.TEXT_FROM_SPEECH)
        node.subscribe(topics.EMOTIONAL_STATE, EmotionalState, self._on_emotion)

    def _report_crash(self, action: str, error: BaseException) -> None:
        """Tell observers that a goal of ``action`` raised (a scenario names it when a step fails)."""
        report = {"module": self.node.name, "action": action, "error": f"{type(error).__name__}: {error}"}
        self._crashes.publish(String(json.dumps(report)))

    def serve(self, name: str, execute: Execute, *, honour_cancel: bool = True) -> StateServer:
        """Offer the action server ``name`` (a state's ``action:`` in the YAML): each goal the
        controller sends runs ``await execute(ctx)``; a new goal or a cancel ends the running one.
        ``honour_cancel=False`` ignores cancels (the controller then aborts after its timeout)."""
        server = StateServer(self, name, execute, honour_cancel=honour_cancel)
        self.servers[name] = server
        return server

    def close(self) -> None:
        """Stop every goal this module runs and withdraw its action servers (see :class:`Component`)."""
        for server in self.servers.values():
            server.close()

    def now(self) -> datetime:
        """The robot's current date-time, an aware UTC datetime (the node's clock: virtual in
        simulations, scenarios and the ModuleHarness); use it instead of ``datetime.now()``."""
        return self.node.clock.datetime()

    def publish_event(self, event: str) -> None:
        """Ask the controller for a state change: published on ``/cyborg_controller/register_event``.
        The controller takes it only if it is a transition of the active state, else drops it."""
        self._events.publish(String(data=event))

    def send_emotion(self, pleasure: float = 0.0, arousal: float = 0.0, dominance: float = 0.0) -> None:
        """Change the robot's emotion by this PAD amount: published on
        ``/cyborg_controller/emotional_feedback``; the emotion system adds it (each value clamped
        to [-1, 1]) unless it is switched off."""
        self._feedback.publish(
            EmotionalFeedback(delta_pleasure=pleasure, delta_arousal=arousal, delta_dominance=dominance)
        )

    def say(self, text: str) -> None:
        """Say ``text``: published on ``/text_to_speech``. The speech gatekeeper passes it to the
        text-to-speech only while the active state grants ``speech`` to this node (its
        ``resources:``), and drops it otherwise."""
        self._speech.publish(String(data=text))

    def on_speech_text(self, callback: Callable[[str, MessageInfo], None]) -> None:
        """Call ``callback(text, info)`` with every sentence heard (``/text_from_speech``), in any state.
        Declare what you listen for in your settings' ``listens_for()``. A text over the API's
        limit (:data:`cyborg.limits.MAX_TEXT_LENGTH` characters) is no sentence: it is not passed
        on (logged once per sender)."""
        limit = self._heard_limit

        def on_text(message: String, info: MessageInfo) -> None:
            if limit.accepts(message.data, info.sender):
                callback(message.data, info)

        self.node.subscribe(topics.TEXT_FROM_SPEECH, String, on_text)

    def on_unsure_speech(self, callback: Callable[[str, str, MessageInfo], None]) -> None:
        """Call ``callback(text, place, info)`` for every sentence the ears heard but are unsure of
        the place in (``/cyborg_speech/unsure``: it never comes on ``/text_from_speech``). A module
        may ask "Did you mean the <place>?" before acting; one that cannot ask should ignore it.
        A message that is not that shape, or over the API's text limit, is left out."""
        limit = TextLimit(topics.SPEECH_UNSURE)

        def on_message(message: String, info: MessageInfo) -> None:
            if not limit.accepts(message.data, info.sender):
                return
            try:
                body = json.loads(message.data)
                text, place = body["text"], body["place"]
            except (ValueError, KeyError, TypeError):
                log.warning(
                    "%s: %s is no unsure sentence: %.80r", self.node.name, topics.SPEECH_UNSURE, message.data
                )
                return
            if isinstance(text, str) and isinstance(place, str) and text and place:
                callback(text, place, info)

        self.node.subscribe(topics.SPEECH_UNSURE, String, on_message)

    def on_muted(self, callback: Callable[[frozenset[str]], None]) -> None:
        """Call ``callback(resources)`` whenever the resources this node is muted on change.

        In a parallel state (docs/parallel.md) a higher-priority region may hold a resource this
        node's state holds too: what it sends there is dropped until the set is empty again. The
        controller says so on ``/cyborg_controller/muted``; a module that must be heard can wait or
        give up (end its goal)."""
        me = normalize_node_name(self.node.name)
        muted: list[frozenset[str]] = [frozenset()]

        def on_message(message: String, info: MessageInfo) -> None:
            try:
                entries = json.loads(message.data).get("muted", [])
                mine = frozenset(
                    str(e["resource"]) for e in entries if normalize_node_name(str(e.get("node", ""))) == me
                )
            except (ValueError, AttributeError, KeyError, TypeError):
                log.warning(
                    "%s: %s is not a list of mutes: %.80r",
                    self.node.name,
                    topics.RESOURCE_MUTES,
                    message.data,
                )
                return
            if mine != muted[0]:
                muted[0] = mine
                try:
                    callback(mine)
                except Exception:
                    log.exception("%s: a mute listener failed; the module carries on", self.node.name)

        self.node.subscribe(topics.RESOURCE_MUTES, String, on_message, queue_size=10)

    def on_emotion_change(self, callback: Callable[[str, str], None]) -> None:
        """Call ``callback(emotion, previous)`` whenever the robot's emotion changes its name."""
        self._emotion_listeners.append(callback)

    def _on_emotion(self, message: EmotionalState, info: MessageInfo) -> None:
        previous, self.emotion = self.emotion, message.to_emotional_state or self.emotion
        if self.emotion != previous:
            for listener in self._emotion_listeners:
                try:
                    listener(self.emotion, previous)
                except Exception:
                    log.exception("%s: an emotion listener failed; the module carries on", self.node.name)
