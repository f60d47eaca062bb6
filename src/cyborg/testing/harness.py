"""Test one behaviour module on its own, in virtual time: a harness with probes.

The harness puts the module on the embedded transport with a virtual clock, plays the
controller (goals and preemption), the people around (what speech-to-text hears) and the
emotion system (the emotion the module sees), and records what the module does::

    from cyborg.testing import ModuleHarness
    from greeter import KIND

    def test_greeter_answers_good_morning() -> None:
        with ModuleHarness(KIND, {"reply": "Morning!"}) as robot:
            robot.hear("Good morning, robot")
            assert robot.events == ["greeting_heard"]
            goal = robot.start("greeter/greet")
            robot.run(5)
            assert robot.said == ["Morning!"] and goal.status is GoalStatus.SUCCEEDED

Everything runs on the harness's clock: ``run(seconds)`` advances it (an hour takes
milliseconds), and nothing else does.
"""

from __future__ import annotations

import asyncio
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from types import TracebackType
from typing import Any

from cyborg.app.context import BuildContext
from cyborg.app.registry import module_kinds
from cyborg.errors import ConfigError
from cyborg.modules.kind import Component, KindSettings, ModuleKind, ServesStates
from cyborg.transport import topics
from cyborg.transport.base import ClientGoalHandle, GoalStatus, MessageInfo, Node
from cyborg.transport.clock import DEFAULT_VIRTUAL_START, VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import (
    EmotionalFeedback,
    EmotionalState,
    StateMachineAction,
    StateMachineFeedback,
    StateMachineGoal,
    StateMachineResult,
    String,
)

__all__ = ["Feedback", "Goal", "GoalStatus", "ModuleHarness"]


@dataclass(frozen=True)
class Feedback:
    """A PAD change the module sent (``send_emotion``), with the clock time it was sent."""

    t: float
    pleasure: float
    arousal: float
    dominance: float

    @property
    def pad(self) -> tuple[float, float, float]:
        return (self.pleasure, self.arousal, self.dominance)


class Goal:
    """A goal the harness sent as the controller would; ``status`` and ``result`` follow it."""

    def __init__(
        self, handle: ClientGoalHandle[StateMachineGoal, StateMachineResult, StateMachineFeedback]
    ) -> None:
        self._handle = handle

    @property
    def status(self) -> GoalStatus:
        return self._handle.status

    @property
    def result(self) -> StateMachineResult | None:
        return self._handle.result

    @property
    def done(self) -> bool:
        return self._handle.status.is_terminal

    def cancel(self) -> None:
        """Preempt it, as the controller does when another state takes over."""
        self._handle.cancel()


def _utc(start: datetime) -> datetime:
    """``start`` as an aware datetime: a naive one is read as UTC (as a scenario's ``start:``)."""
    return start.replace(tzinfo=UTC) if start.tzinfo is None else start


class ModuleHarness:
    """One module on its own node (``node_name``), in virtual time, with probes.

    ``module`` is a :class:`ModuleKind` with its settings (a mapping, validated as the YAML's
    block would be, or a settings object), the name of an installed kind, or a factory
    ``build(node) -> component``. Probes: ``said`` (what it published on ``/text_to_speech``),
    ``events`` (``register_event``), ``feedback`` (:class:`Feedback`); ``hear()``,
    ``set_emotion()``, ``start()`` and ``run()`` drive it. Close it (or use ``with``).

    The virtual clock starts at ``start`` (a datetime; a naive one is UTC), by default at
    2026-11-23 09:00 UTC (a Monday); the module reads it with ``self.now()`` or ``ctx.now()``.
    """

    def __init__(
        self,
        module: ModuleKind[Any] | str | Callable[[Node], Component],
        settings: Mapping[str, Any] | KindSettings | None = None,
        *,
        node_name: str = "module",
        data_dir: Path | None = None,
        map_path: Path | None = None,
        seed: int = 0,
        start: datetime | None = None,
    ) -> None:
        self.clock = VirtualClock(DEFAULT_VIRTUAL_START if start is None else _utc(start))
        self.transport = EmbeddedTransport(self.clock)
        self._tmp = tempfile.TemporaryDirectory(prefix="cyborg-test-") if data_dir is None else None
        folder = data_dir if data_dir is not None else Path(self._tmp.name) if self._tmp else Path()
        self.place = BuildContext(data_dir=folder, seed=seed, map_path=map_path)
        self.said: list[str] = []
        self.events: list[str] = []
        self.feedback: list[Feedback] = []
        self.emotion = "neutral"
        probe = self.transport.node("cyborg_test_probe")
        self._probe = probe
        probe.subscribe(topics.TEXT_TO_SPEECH, String, self._on_say, queue_size=1000)
        probe.subscribe(topics.REGISTER_EVENT, String, self._on_event, queue_size=1000)
        probe.subscribe(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback, self._on_feedback, queue_size=1000)
        self._hear = probe.publisher(topics.TEXT_FROM_SPEECH, String)
        self._emotion = probe.publisher(topics.EMOTIONAL_STATE, EmotionalState, latch=True)
        try:
            self.module = self._build(module, settings, node_name)
        except BaseException:
            self.transport.shutdown()
            self.clock.close()
            if self._tmp is not None:
                self._tmp.cleanup()
            raise
        self.run(0)

    def _build(
        self,
        module: ModuleKind[Any] | str | Callable[[Node], Component],
        settings: Mapping[str, Any] | KindSettings | None,
        node_name: str,
    ) -> Component:
        node = self.transport.node(node_name)
        if callable(module) and not isinstance(module, ModuleKind):
            return module(node)
        kind = module_kinds().get(module) if isinstance(module, str) else module
        if isinstance(settings, KindSettings):
            chosen = settings
        else:
            _, chosen = module_kinds({"under_test": kind}).parse(
                node_name, {"kind": "under_test", **(settings or {})}, source="ModuleHarness settings"
            )
        return kind.build(node, chosen, self.place.for_module(node_name))

    # --- what the module does -----------------------------------------------------------

    def _on_say(self, message: String, info: MessageInfo) -> None:
        if info.sender == self.module.node.name:
            self.said.append(message.data)

    def _on_event(self, message: String, info: MessageInfo) -> None:
        if info.sender == self.module.node.name:
            self.events.append(message.data)

    def _on_feedback(self, message: EmotionalFeedback, info: MessageInfo) -> None:
        if info.sender == self.module.node.name:
            self.feedback.append(
                Feedback(
                    self.clock.now(), message.delta_pleasure, message.delta_arousal, message.delta_dominance
                )
            )

    # --- driving it ------------------------------------------------------------------------

    def run(self, seconds: float) -> None:
        """Let ``seconds`` of virtual time pass (the module's timers and goals run meanwhile)."""

        async def pass_time() -> None:
            await self.clock.sleep(seconds)
            for _ in range(10):  # what was published at the end is delivered too
                await asyncio.sleep(0)

        self.clock.run(pass_time())

    def hear(self, text: str, *, then: float = 0.1) -> None:
        """Speech-to-text hears ``text`` (``/text_from_speech``); then ``then`` seconds pass."""
        self._hear.publish(String(text))
        self.run(then)

    def set_emotion(self, emotion: str, pad: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        """The emotion system announces ``emotion`` (as on ``/cyborg_controller/emotional_state``)."""
        previous, self.emotion = self.emotion, emotion
        self._emotion.publish(EmotionalState(previous, emotion, *pad))
        self.run(0)

    def start(self, action: str | None = None, *, event: str = "", previous_state: str = "idle") -> Goal:
        """Send a goal to the module's action server ``action`` (default: its only one), as the
        controller does when it enters the state; returns the :class:`Goal` to watch."""
        if action is None:
            served = list(self.module.servers) if isinstance(self.module, ServesStates) else []
            if len(served) != 1:
                raise ConfigError(
                    f"the module serves {served or 'no action'}; fix: name the action, e.g. start({served[0]!r})"
                    if served
                    else "the module serves no action; fix: call serve() in its __init__"
                )
            action = served[0]
        client = self._probe.action_client(action, StateMachineAction)
        goal = Goal(client.send_goal(StateMachineGoal(previous_state, event, action.split("/")[-1])))
        self.run(0)
        return goal

    def close(self) -> None:
        """Close the module and the transport; the temporary data folder goes too."""
        try:
            self.module.close()
            self.run(0)
        finally:
            self.transport.shutdown()
            self.clock.close()
            if self._tmp is not None:
                self._tmp.cleanup()

    def __enter__(self) -> ModuleHarness:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
