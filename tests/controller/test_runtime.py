"""The controller at run time, on the embedded transport in virtual time."""

from __future__ import annotations

from typing import Any

import pytest

from cyborg.controller.config import parse_config
from cyborg.controller.runtime import Controller
from cyborg.modules.helper import Abort, BehaviourModule, GoalContext
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String, SystemState

MACHINE = """
timeouts: {connect: 1.0, preempt: 0.5}
states:
  idle:
    action: m/idle
    transitions: {play: music, tell: joke, aborted: idle, missing: ghost}
  music:
    action: m/music
    transitions: {succeeded: idle, aborted: idle, tell: joke}
    resources: {speaker: music_node}
  joke:
    action: m/joke
    transitions: {aborted: idle}
  ghost:
    action: nobody/here
    transitions: {aborted: idle}
"""


class Recorder:
    """Records state changes and what /state_resources held when each arrived."""

    def __init__(self, transport: EmbeddedTransport) -> None:
        self.node = transport.node("recorder")
        self.changes: list[tuple[str, str, str]] = []
        self.resources_at_change: list[Any] = []
        self.node.subscribe(topics.STATE_CHANGE, SystemState, self._on_change)
        self.events = self.node.publisher(topics.REGISTER_EVENT, String)

    def _on_change(self, msg: SystemState, info: MessageInfo) -> None:
        self.changes.append((msg.from_system_state, msg.event, msg.to_system_state))
        self.resources_at_change.append(self.node.get_param(topics.STATE_RESOURCES_PARAM))

    def send(self, event: str) -> None:
        self.events.publish(String(event))


class Modules(BehaviourModule):
    def __init__(
        self, transport: EmbeddedTransport, *, joke_ignores_cancel: bool = False, music_seconds: float = 5
    ) -> None:
        super().__init__(transport.node("modules"))
        self.log: list[str] = []
        self.music_seconds = music_seconds
        self.serve("m/idle", self.idle)
        self.serve("m/music", self.music)
        self.serve("m/joke", self.joke, honour_cancel=not joke_ignores_cancel)

    async def idle(self, ctx: GoalContext) -> None:
        self.log.append(f"idle start ({ctx.event})")
        try:
            await ctx.wait_forever()
        finally:
            self.log.append("idle stop")

    async def music(self, ctx: GoalContext) -> None:
        self.log.append("music start")
        await ctx.sleep(self.music_seconds)
        self.log.append("music done")

    async def joke(self, ctx: GoalContext) -> None:
        self.log.append("joke start")
        await ctx.sleep(1)
        raise Abort("forgot the punchline")


def setup(clock: VirtualClock, **kw: Any) -> tuple[EmbeddedTransport, Controller, Recorder, Modules]:
    transport = EmbeddedTransport(clock)
    modules = Modules(transport, **kw)
    recorder = Recorder(transport)
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)
    controller.start()
    return transport, controller, recorder, modules


def test_starts_in_initial_state_and_sends_its_goal(clock: VirtualClock) -> None:
    _, controller, recorder, modules = setup(clock)
    clock.run(clock.sleep(0.1))
    assert recorder.changes == [("", "start", "idle")]
    assert modules.log == ["idle start (start)"]
    assert controller.goal_status is GoalStatus.ACTIVE


def test_event_preempts_then_enters_next_state(clock: VirtualClock) -> None:
    _, controller, recorder, modules = setup(clock)

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("play")
        await clock.sleep(0.1)

    clock.run(main())
    assert recorder.changes[-1] == ("idle", "play", "music")
    # the idle module stopped before music started: never two in control
    assert modules.log == ["idle start (start)", "idle stop", "music start"]
    assert controller.active_state == "music"


def test_module_success_gives_succeeded_event(clock: VirtualClock) -> None:
    _, _, recorder, _ = setup(clock)

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("play")
        await clock.sleep(6)

    clock.run(main())
    assert recorder.changes[-1] == ("music", "succeeded", "idle")


def test_module_abort_gives_aborted_event(clock: VirtualClock) -> None:
    _, _, recorder, _ = setup(clock)

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("tell")
        await clock.sleep(2)

    clock.run(main())
    assert recorder.changes[-1] == ("joke", "aborted", "idle")


def test_resources_are_set_before_the_change_is_published(clock: VirtualClock) -> None:
    _, _, recorder, _ = setup(clock)

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("play")
        await clock.sleep(0.1)

    clock.run(main())
    assert recorder.resources_at_change == [{}, {"speaker": "music_node"}]


def test_invalid_events_are_dropped_and_counted(clock: VirtualClock) -> None:
    _, controller, recorder, _ = setup(clock)

    async def main() -> None:
        await clock.sleep(0.1)
        for _ in range(3):
            recorder.send("no_such_event")
        await clock.sleep(0.1)

    clock.run(main())
    assert controller.stats.events_invalid == 3
    assert recorder.changes == [("", "start", "idle")]


def test_missing_action_server_takes_aborted_after_connect_timeout(clock: VirtualClock) -> None:
    _, controller, recorder, _ = setup(clock)

    async def main() -> float:
        await clock.sleep(0.1)
        recorder.send("missing")
        start = clock.monotonic()
        while recorder.changes[-1][2] != "idle" or len(recorder.changes) < 3:
            await clock.sleep(0.01)
        return clock.monotonic() - start

    waited = clock.run(main())
    assert recorder.changes[1:] == [("idle", "missing", "ghost"), ("ghost", "aborted", "idle")]
    assert waited == pytest.approx(1.0, abs=0.05)
    assert controller.stats.connect_failures == 1


def test_preempt_timeout_is_counted_and_handover_goes_on(clock: VirtualClock) -> None:
    transport = EmbeddedTransport(clock)
    stubborn = BehaviourModule(transport.node("stubborn"))

    async def forever(ctx: GoalContext) -> None:
        await ctx.wait_forever()

    stubborn.serve("m/idle", forever, honour_cancel=False)
    other = Modules.__new__(Modules)
    BehaviourModule.__init__(other, transport.node("others"))
    other.log = []
    other.music_seconds = 5
    other.serve("m/music", other.music)
    recorder = Recorder(transport)
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)
    controller.start()

    async def main() -> float:
        await clock.sleep(0.1)
        recorder.send("play")
        start = clock.monotonic()
        while controller.active_state != "music":
            await clock.sleep(0.01)
        return clock.monotonic() - start

    waited = clock.run(main())
    assert waited == pytest.approx(0.5, abs=0.05)
    assert controller.stats.preempt_timeouts == 1
    assert recorder.changes[-1] == ("idle", "play", "music")


def test_events_during_handover_are_handled_in_order_afterwards(clock: VirtualClock) -> None:
    _, _, recorder, modules = setup(clock, music_seconds=100)

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("play")
        recorder.send("tell")  # arrives while idle is being preempted; valid in music
        await clock.sleep(0.1)

    clock.run(main())
    assert [c[1:] for c in recorder.changes] == [("start", "idle"), ("play", "music"), ("tell", "joke")]
    # music was preempted before its execute callback ever ran; it was never in control with joke
    assert modules.log == ["idle start (start)", "idle stop", "joke start"]


def test_crashing_module_is_aborted_and_controller_survives(clock: VirtualClock) -> None:
    transport = EmbeddedTransport(clock)
    module = BehaviourModule(transport.node("buggy"))

    async def idle(ctx: GoalContext) -> None:
        await ctx.wait_forever()

    async def crash(ctx: GoalContext) -> None:
        raise ZeroDivisionError("student bug")

    module.serve("m/idle", idle)
    module.serve("m/music", crash)
    recorder = Recorder(transport)
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)
    controller.start()

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("play")
        await clock.sleep(0.1)

    clock.run(main())
    assert recorder.changes[-1] == ("music", "aborted", "idle")
    assert controller.active_state == "idle"


def test_success_without_succeeded_transition_falls_back_to_aborted(clock: VirtualClock) -> None:
    transport = EmbeddedTransport(clock)
    module = BehaviourModule(transport.node("mods"))

    async def idle(ctx: GoalContext) -> None:
        await ctx.wait_forever()

    async def quick(ctx: GoalContext) -> None:
        await ctx.sleep(1)

    module.serve("m/idle", idle)
    module.serve("m/joke", quick)  # joke has no 'succeeded' transition
    recorder = Recorder(transport)
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)
    controller.start()

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("tell")
        await clock.sleep(2)

    clock.run(main())
    assert recorder.changes[-1] == ("joke", "succeeded", "idle")
    assert controller.stats.succeeded_fallbacks == 1
