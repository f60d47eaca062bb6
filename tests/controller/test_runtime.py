"""The controller at run time, on the embedded transport in virtual time."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import pytest

from cyborg.app.config import parse_config
from cyborg.controller.runtime import Controller
from cyborg.modules.behaviour import Abort, BehaviourModule, GoalContext
from cyborg.testing import wait_until
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, MessageInfo, ServerGoalHandle
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import StateMachineAction, StateMachineResult, String, SystemState

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
    """Records the published state changes and sends events."""

    def __init__(self, transport: EmbeddedTransport) -> None:
        self.node = transport.node("recorder")
        self.changes: list[tuple[str, str, str]] = []
        self.node.subscribe(topics.STATE_CHANGE, SystemState, self._on_change)
        self.events = self.node.publisher(topics.REGISTER_EVENT, String)

    def _on_change(self, msg: SystemState, info: MessageInfo) -> None:
        self.changes.append((msg.from_system_state, msg.event, msg.to_system_state))

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


async def until(clock: VirtualClock, condition: Callable[[], bool], timeout: float = 5.0) -> float:
    """Seconds until ``condition`` holds, polled every millisecond; fails after ``timeout`` (virtual) s."""
    start = clock.monotonic()
    assert await wait_until(condition, clock, timeout=timeout, interval=0.001), f"not met within {timeout} s"
    return clock.monotonic() - start


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


def test_resources_are_set_before_the_change_is_published(
    clock: VirtualClock, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A gatekeeper that reads /state_resources when the change arrives must see the new owner.

    The parameter is read synchronously inside the controller's publish call, so the check
    fails if the controller publishes first and sets the parameter afterwards.
    """
    transport = EmbeddedTransport(clock)
    Modules(transport)
    recorder = Recorder(transport)
    node = transport.node("cyborg_controller")
    at_publish: list[tuple[str, Any]] = []
    make_publisher = node.publisher

    def publisher(topic: str, msg_type: Any, **kw: Any) -> Any:
        pub = make_publisher(topic, msg_type, **kw)
        if topic == topics.STATE_CHANGE:
            publish = pub.publish

            def read_then_publish(message: SystemState) -> None:
                at_publish.append((message.to_system_state, node.get_param(topics.STATE_RESOURCES_PARAM)))
                publish(message)

            monkeypatch.setattr(pub, "publish", read_then_publish)
        return pub

    monkeypatch.setattr(node, "publisher", publisher)
    Controller(node, parse_config(MACHINE).machine).start()

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("play")
        await clock.sleep(0.1)
        recorder.send("tell")
        await clock.sleep(0.1)

    clock.run(main())
    assert at_publish == [("idle", {}), ("music", {"speaker": "music_node"}), ("joke", {})]
    assert [c[2] for c in recorder.changes] == ["idle", "music", "joke"]


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
        return await until(clock, lambda: recorder.changes[-1][2] == "idle" and len(recorder.changes) >= 3)

    waited = clock.run(main())
    assert recorder.changes[1:] == [("idle", "missing", "ghost"), ("ghost", "aborted", "idle")]
    assert waited == pytest.approx(1.0, abs=0.05)
    assert controller.stats.connect_failures == 1


def test_preempt_timeout_is_counted_logged_and_handover_goes_on(
    clock: VirtualClock, caplog: pytest.LogCaptureFixture
) -> None:
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
        return await until(clock, lambda: controller.active_state == "music")

    with caplog.at_level(logging.WARNING, logger="cyborg.controller.runtime"):
        waited = clock.run(main())
    assert waited == pytest.approx(0.5, abs=0.05)
    assert controller.stats.preempt_timeouts == 1
    assert recorder.changes[-1] == ("idle", "play", "music")
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == ["module of idle did not acknowledge the cancel within 0.5 s; handing over anyway"]


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


# A machine whose 'aborted' from music leads somewhere else than where music came from, so the
# tests below see that the controller followed the 'aborted' transition and not some default.
APOLOGY = """
timeouts: {connect: 1.0, preempt: 0.5}
states:
  idle: {action: m/idle, transitions: {play: music, aborted: idle}}
  music: {action: m/music, transitions: {succeeded: idle, aborted: sorry}}
  sorry: {action: m/sorry, transitions: {succeeded: idle, aborted: idle}}
"""


async def _wait_forever(ctx: GoalContext) -> None:
    await ctx.wait_forever()


def _apology_setup(transport: EmbeddedTransport) -> tuple[Controller, Recorder, list[str]]:
    """idle and sorry served by well-behaved modules; the test provides m/music."""
    helpers = BehaviourModule(transport.node("helpers"))
    sorry_events: list[str] = []

    async def sorry(ctx: GoalContext) -> None:
        sorry_events.append(f"{ctx.previous_state} --{ctx.event}-->")
        await ctx.wait_forever()

    helpers.serve("m/idle", _wait_forever)
    helpers.serve("m/sorry", sorry)
    recorder = Recorder(transport)
    controller = Controller(transport.node("cyborg_controller"), parse_config(APOLOGY).machine)
    controller.start()
    return controller, recorder, sorry_events


def test_rejected_goal_takes_the_aborted_transition(
    clock: VirtualClock, caplog: pytest.LogCaptureFixture
) -> None:
    transport = EmbeddedTransport(clock)
    controller, recorder, sorry_events = _apology_setup(transport)

    def refuse(handle: ServerGoalHandle[Any, Any, Any]) -> None:
        handle.reject(StateMachineResult(status="rejected"), "busy with another client")

    transport.node("refuser").action_server("m/music", StateMachineAction, refuse, lambda h: None)

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("play")
        await clock.sleep(0.1)

    with caplog.at_level(logging.INFO, logger="cyborg.controller.runtime"):
        clock.run(main())
    assert recorder.changes == [
        ("", "start", "idle"),
        ("idle", "play", "music"),
        ("music", "aborted", "sorry"),
    ]
    assert sorry_events == ["music --aborted-->"]
    assert controller.active_state == "sorry"
    assert "module of music ended REJECTED (busy with another client): event 'aborted'" in caplog.text


def test_server_vanishing_mid_goal_takes_the_aborted_transition_at_once(
    clock: VirtualClock, caplog: pytest.LogCaptureFixture
) -> None:
    transport = EmbeddedTransport(clock)
    controller, recorder, sorry_events = _apology_setup(transport)
    music_node = transport.node("music_module")
    music = BehaviourModule(music_node)
    music.serve("m/music", _wait_forever)

    async def main() -> float:
        await clock.sleep(0.1)
        recorder.send("play")
        await clock.sleep(0.5)
        assert controller.goal_status is GoalStatus.ACTIVE
        music_node.shutdown()  # the module's process dies: its action server is gone
        return await until(clock, lambda: controller.active_state == "sorry")

    with caplog.at_level(logging.INFO, logger="cyborg.controller.runtime"):
        noticed_after = clock.run(main())
    assert noticed_after < 0.01  # no connect or preempt timeout in between
    assert recorder.changes[1:] == [("idle", "play", "music"), ("music", "aborted", "sorry")]
    assert sorry_events == ["music --aborted-->"]
    assert "module of music ended LOST (server gone): event 'aborted'" in caplog.text


CHAIN = """
timeouts: {connect: 1.0, preempt: 0.5}
states:
  idle: {action: m/idle, transitions: {go: a, aborted: idle}}
  a: {action: m/a, transitions: {to_b: b, reset: idle, aborted: idle}}
  b: {action: m/b, transitions: {to_c: c, reset: idle, aborted: idle}}
  c: {action: m/c, transitions: {to_d: d, reset: idle, aborted: idle}}
  d: {action: m/d, transitions: {reset: idle, aborted: idle}}
"""


def test_event_queue_overflow_during_handover_is_counted_summed_up_and_the_rest_handled_in_order(
    clock: VirtualClock, caplog: pytest.LogCaptureFixture
) -> None:
    transport = EmbeddedTransport(clock)
    stubborn = BehaviourModule(transport.node("stubborn"))
    stubborn.serve("m/idle", _wait_forever, honour_cancel=False)  # handover takes the 0.5 s timeout
    chain = BehaviourModule(transport.node("chain"))
    for name in "abcd":
        chain.serve(f"m/{name}", _wait_forever)
    recorder = Recorder(transport)
    controller = Controller(
        transport.node("cyborg_controller"), parse_config(CHAIN).machine, event_queue_size=3
    )
    controller.start()

    async def main() -> None:
        await clock.sleep(0.1)
        recorder.send("go")
        # While idle ignores its cancel: three events fit in the queue, two do not.
        for event in ("to_b", "to_c", "to_d", "reset", "reset"):
            await clock.sleep(0.01)
            assert controller.active_state == "idle"
            recorder.send(event)
        await clock.sleep(11.0)  # past the summary of the drops

    with caplog.at_level(logging.WARNING, logger="cyborg.controller.runtime"):
        clock.run(main())
    assert [c[1:] for c in recorder.changes] == [
        ("start", "idle"),
        ("go", "a"),
        ("to_b", "b"),
        ("to_c", "c"),
        ("to_d", "d"),
    ]
    assert controller.stats.events_overflow == 2
    assert controller.stats.preempt_timeouts == 1
    dropped = [r.getMessage() for r in caplog.records if "dropped" in r.getMessage()]
    assert len(dropped) == 2, dropped  # the first drop, then one summary: not a line per drop
    assert dropped[0].startswith("event 'reset' from recorder dropped: 3 events already queued, the limit;")
    assert dropped[1] == "dropped 1 more event(s) in the last 10 s (1 overflow); sent by recorder 1"


def test_module_rejecting_every_goal_is_retried_once_per_connect_timeout_not_flooded(
    clock: VirtualClock, caplog: pytest.LogCaptureFixture
) -> None:
    transport = EmbeddedTransport(clock)
    refused_at: list[float] = []
    refuser = transport.node("refuser")

    def refuse(handle: ServerGoalHandle[Any, Any, Any]) -> None:
        refused_at.append(round(clock.monotonic(), 3))
        handle.reject(StateMachineResult(status="rejected"), "broken")
        if len(refused_at) >= 20:  # flooded: stop serving so the test fails instead of spinning
            refuser.shutdown()

    refuser.action_server("m/idle", StateMachineAction, refuse, lambda h: None)
    music = BehaviourModule(transport.node("music"))
    music.serve("m/music", _wait_forever)
    recorder = Recorder(transport)
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)
    controller.start()

    async def main() -> float:
        await clock.sleep(0.3)
        recorder.send("bogus")  # no transition of idle: must not stop the retries
        await clock.sleep(2.0)
        recorder.send("play")  # valid: handled at once, not after the retry delay
        return await until(clock, lambda: controller.active_state == "music")

    with caplog.at_level(logging.WARNING, logger="cyborg.controller.runtime"):
        reaction = clock.run(main())
    assert refused_at == [0.0, 1.0, 2.0]  # connect timeout 1.0 s between goals
    assert recorder.changes == [
        ("", "start", "idle"),
        ("idle", "aborted", "idle"),
        ("idle", "aborted", "idle"),
        ("idle", "play", "music"),
    ]
    assert reaction < 0.01
    assert controller.stats.retries_delayed == 3
    assert "module of idle ended ('aborted') 0.00 s after its goal; re-entering idle in 1.00 s" in caplog.text
