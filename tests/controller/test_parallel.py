"""Parallel states at run time, on the embedded transport in virtual time.

A robot in ``busy`` runs a behaviour region (music, chat) and a higher-priority monitor
region (ok, greet, warning) at once. Both music and greet want the speaker, which is
arbitrated: the monitor's greet wins and music is muted.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cyborg.app.config import load_config, packaged_config, parse_config
from cyborg.app.robot import build_robot
from cyborg.controller.runtime import Controller
from cyborg.modules.behaviour import Abort, BehaviourModule, GoalContext
from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String, SystemState

PREEMPT = 0.5
MACHINE = f"""
initial: idle
timeouts: {{connect: 1.0, preempt: {PREEMPT}}}
resource_policy: {{speaker: arbitrated}}
states:
  idle:
    action: idle_node/run
    transitions: {{go: busy, aborted: idle}}
  busy:
    parallel: true
    transitions: {{stop: idle, aborted: idle}}
    states:
      behaviour:
        priority: 1
        states:
          music: {{action: music_node/run, resources: {{speaker: music_node}}, transitions: {{face_seen: chat}}}}
          chat: {{action: chat_node/run, transitions: {{succeeded: music, done: finished}}}}
      monitor:
        priority: 10
        states:
          ok: {{action: ok_node/run, transitions: {{face_seen: greet, hello: greet}}}}
          greet: {{action: greet_node/run, resources: {{speaker: greet_node}}, transitions: {{succeeded: ok}}}}
  finished:
    action: idle_node/finished
    transitions: {{aborted: idle}}
"""
NODES = ["idle_node", "music_node", "chat_node", "ok_node", "greet_node"]


class World:
    """One module node per state, each speaking on the speaker's input while its goal runs."""

    def __init__(
        self,
        clock: VirtualClock,
        *,
        stubborn: frozenset[str] = frozenset(),
        seconds: dict[str, float] | None = None,
        speak_every: float = 0.0,
    ) -> None:
        self.clock = clock
        self.transport = EmbeddedTransport(clock)
        self.log: list[str] = []
        self.seconds = seconds or {}
        self.speak_every = speak_every
        self.modules: list[BehaviourModule] = []
        self.music_muted: list[frozenset[str]] = []
        for name in NODES:
            module = BehaviourModule(self.transport.node(name))
            speaker = module.node.publisher("/speaker_in", String)
            label = name.removesuffix("_node")
            module.serve(f"{name}/run", self._serve(label, speaker), honour_cancel=label not in stubborn)
            if name == "music_node":
                module.on_muted(self.music_muted.append)
            if name == "idle_node":
                module.serve("idle_node/finished", self._serve("finished", speaker))
            self.modules.append(module)
        observer = self.transport.node("observer")
        self.changes: list[tuple[str, str, str]] = []
        self.mutes: list[dict[str, Any]] = []
        self.heard: list[tuple[float, str]] = []
        observer.subscribe(topics.STATE_CHANGE, SystemState, self._on_change, queue_size=1000)
        observer.subscribe(topics.RESOURCE_MUTES, String, lambda m, i: self.mutes.append(json.loads(m.data)))
        observer.subscribe("/speaker_out", String, self._on_heard, queue_size=1000)
        self.events = observer.publisher(topics.REGISTER_EVENT, String)
        self.gatekeeper = Gatekeeper(
            self.transport.node("speaker_gatekeeper"),
            input_topic="/speaker_in",
            output_topic="/speaker_out",
            resource="speaker",
        )
        self.controller = Controller(self.transport.node("cyborg_controller"), parse_config(MACHINE).machine)
        self.controller.start()

    def _serve(self, name: str, speaker: Any) -> Any:
        async def execute(ctx: GoalContext) -> None:
            self.log.append(f"{name} start")
            try:
                seconds = self.seconds.get(name)
                if self.speak_every:
                    while seconds is None or seconds > 0:
                        speaker.publish(String(name))
                        await ctx.sleep(self.speak_every)
                        seconds = None if seconds is None else seconds - self.speak_every
                elif seconds is not None:
                    await ctx.sleep(seconds)
                else:
                    await ctx.wait_forever()
            finally:
                self.log.append(f"{name} stop")

        return execute

    def _on_change(self, message: SystemState, info: MessageInfo) -> None:
        self.changes.append((message.from_system_state, message.event, message.to_system_state))

    def _on_heard(self, message: String, info: MessageInfo) -> None:
        self.heard.append((self.clock.monotonic(), message.data))

    def send(self, event: str) -> None:
        self.events.publish(String(event))

    def run(self, *script: tuple[float, str], until: float = 0.5) -> None:
        async def main() -> None:
            for gap, event in script:
                await self.clock.sleep(gap)
                self.send(event)
            await self.clock.sleep(until)

        self.clock.run(main())


def test_entering_starts_every_region_and_grants_the_speaker_to_the_higher_priority(
    clock: VirtualClock,
) -> None:
    world = World(clock)
    world.run((0.1, "go"), (0.1, "hello"))
    assert world.changes == [
        ("", "start", "idle"),
        ("idle", "go", "ok"),  # the monitor first: regions by priority
        ("idle", "go", "music"),
        ("ok", "hello", "greet"),
    ]
    assert world.controller.active_regions() == {"monitor": "greet", "behaviour": "music"}
    assert "ok start" in world.log and "music start" in world.log and "idle stop" in world.log
    node = world.controller.node
    assert node.get_param(topics.STATE_RESOURCES_PARAM) == {"speaker": "greet_node"}
    muted = world.mutes[-1]["muted"]
    assert muted == [
        {
            "resource": "speaker",
            "node": "music_node",
            "state": "music",
            "region": "behaviour",
            "holder": "greet_node",
        }
    ]
    assert world.controller.stats.resource_mutes == 1
    assert world.controller.stats.resource_grants == 2  # music alone, then greet over music


def test_the_muted_module_is_not_heard_while_the_higher_priority_one_speaks(clock: VirtualClock) -> None:
    world = World(clock, seconds={"greet": 0.5}, speak_every=0.1)
    world.run((0.1, "go"), until=0.5)
    assert {who for _, who in world.heard} == {"music"}
    hello = clock.monotonic() + 0.05  # between two of music's lines
    world.run((0.05, "hello"), until=0.4)
    assert {who for at, who in world.heard if at > hello} == {"greet"}, "music is muted while greet speaks"
    back = clock.monotonic() + 0.1
    world.run(until=0.5)  # greet succeeded (0.5 s): back to ok, music is heard again
    assert {who for at, who in world.heard if at > back} == {"music"}
    assert world.gatekeeper.stats.dropped_by_sender["music_node"] >= 3
    assert world.music_muted == [frozenset({"speaker"}), frozenset()], "music learnt it was muted, then heard"


def test_an_event_moves_every_region_that_takes_it_and_no_other(clock: VirtualClock) -> None:
    world = World(clock)
    world.run((0.1, "go"), (0.1, "face_seen"))
    assert world.changes[-2:] == [("ok", "face_seen", "greet"), ("music", "face_seen", "chat")]
    world.log.clear()
    world.run((0.0, "done"))  # only chat takes it, and it leaves the parallel state
    assert world.changes[-1] == ("greet", "done", "finished")
    assert sorted(world.log) == ["chat stop", "finished start", "greet stop"]


def test_a_modules_result_moves_only_its_own_region(clock: VirtualClock) -> None:
    world = World(clock, seconds={"greet": 1.0})
    world.run((0.1, "go"), (0.1, "hello"), until=1.5)
    assert world.changes[-1] == ("greet", "succeeded", "ok")
    assert world.controller.active_regions() == {"monitor": "ok", "behaviour": "music"}
    assert world.log.count("music start") == 1  # never restarted


def _leave_busy(clock: VirtualClock, stubborn: frozenset[str]) -> tuple[World, float]:
    """Enter busy (greet and music), send stop: the world and how long until idle was entered."""
    world = World(clock, stubborn=stubborn)
    world.run((0.1, "go"), (0.1, "hello"))
    left_at = clock.monotonic()
    world.send("stop")
    entered: list[float] = []
    world.controller.add_state_listener(lambda change: entered.append(clock.monotonic()))
    world.run(until=3 * PREEMPT)
    world.transport.shutdown()
    return world, entered[0] - left_at


def test_leaving_cancels_every_region_at_once_within_the_preempt_limit_even_if_one_ignores_it(
    clock: VirtualClock,
) -> None:
    for stubborn, timeouts in ((frozenset({"music"}), 1), (frozenset({"music", "greet"}), 2)):
        world, took = _leave_busy(clock, stubborn)
        assert world.changes[-1] == ("greet", "stop", "idle")
        assert took <= PREEMPT + 0.01, "the regions are waited for together, not one after the other"
        assert world.controller.stats.preempt_timeouts == timeouts  # one per module that ignored the cancel
        assert ("greet stop" in world.log) == ("greet" not in stubborn) and "music stop" not in world.log


def _finish_as_the_preempt_arrives(after: float) -> list[tuple[str, str, str]]:
    """greet's module ends 1 s after it started; ``stop`` (leave the parallel state) comes ``after`` that."""
    clock = VirtualClock()
    try:
        world = World(clock, seconds={"greet": 1.0})
        world.run((0.1, "go"), (0.1, "hello"), until=0.0)
        started = clock.monotonic()
        clock.loop.call_at(started + 1.0 + after, world.send, "stop")
        world.run(until=2.0)
        assert world.controller.active_states == ("idle",)
        assert world.log[-1] == "idle start" and world.log.count("idle start") == 2
        return world.changes[4:]
    finally:
        clock.close()


def test_a_preempt_arriving_as_a_region_finishes_ends_one_way_every_time() -> None:
    result_first = [("greet", "succeeded", "ok"), ("ok", "stop", "idle")]
    preempt_first = [("greet", "stop", "idle")]  # greet's result, come too late, is ignored
    assert _finish_as_the_preempt_arrives(0.001) == result_first
    assert _finish_as_the_preempt_arrives(-0.001) == preempt_first
    same_instant = _finish_as_the_preempt_arrives(0.0)
    assert same_instant in (result_first, preempt_first)
    for _ in range(3):
        assert _finish_as_the_preempt_arrives(0.0) == same_instant


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    script=st.lists(
        st.tuples(
            st.floats(min_value=0.0, max_value=0.4),
            st.sampled_from(["go", "face_seen", "hello", "stop", "done"]),
        ),
        max_size=15,
    )
)
def test_two_regions_wanting_the_speaker_never_both_pass(script: list[tuple[float, str]]) -> None:
    clock = VirtualClock()
    try:
        world = World(clock, seconds={"greet": 0.3, "chat": 0.35}, speak_every=0.05)
        since: list[tuple[float, tuple[str, ...]]] = []
        world.controller.add_state_listener(
            lambda change: since.append((clock.monotonic(), world.controller.active_states))
        )
        world.run((0.05, "go"), *script, until=0.5)
    finally:
        clock.close()
    for at, speaker in world.heard:
        # at a change's own instant, the message may have passed just before or just after it
        settled = [config for start, config in since if start < at][-1:]
        now = [config for start, config in since if start == at]
        allowed = {_speaker_holder(config) for config in settled + now}
        assert speaker in allowed, f"{speaker} passed at {at}; only {allowed} may speak then"


def _speaker_holder(config: tuple[str, ...]) -> str | None:
    """Who may speak: greet over music (the monitor region outranks the behaviour region)."""
    return "greet" if "greet" in config else "music" if "music" in config else None


def test_the_packaged_monitor_robot_warns_about_the_battery_over_whatever_it_is_doing(
    clock: VirtualClock, tmp_path: Path
) -> None:
    transport = EmbeddedTransport(clock)
    robot = build_robot(load_config(packaged_config("monitor.yaml")), transport, data_dir=tmp_path)
    listener = transport.node("listener")
    said: list[tuple[float, str]] = []
    dropped: list[dict[str, Any]] = []
    listener.subscribe("/cyborg_tts/say", String, lambda m, i: said.append((clock.monotonic(), m.data)))
    listener.subscribe(topics.GATEKEEPER_DROPPED, String, lambda m, i: dropped.append(json.loads(m.data)))
    events = listener.publisher(topics.REGISTER_EVENT, String)

    async def main() -> None:
        await clock.sleep(5)  # nothing from the stand-ins yet (their first events come at 12 and 40 s)
        events.publish(String("battery_low"))
        await clock.sleep(1)
        events.publish(String("music_play"))  # during the warning: the tune's sentence is muted
        await clock.sleep(84)

    robot.start()
    try:
        clock.run(main())
    finally:
        robot.close()
    warnings = [at for at, text in said if "battery is getting low" in text]
    assert warnings[0] == 5 and len(warnings) == 3  # ours, then the sensor stand-in's at 40 and 80 s
    assert dropped[0]["sender"] == "cyborg_music" and dropped[0]["holder"] == "cyborg_battery"
    assert any("little tune" in text for _, text in said) and any("cafeteria" in text for _, text in said)
    assert {d["holder"] for d in dropped} == {"cyborg_battery"}
    assert robot.controller.stats.resource_mutes >= 1


FLAKY_REGION = """
initial: busy
timeouts: {connect: 1.0, preempt: 0.5}
states:
  busy:
    parallel: true
    states:
      steady:
        priority: 1
        states:
          s1: {action: steady_node/run, transitions: {aborted: s1}}
      flaky:
        priority: 2
        states:
          f1: {action: flaky_node/run, transitions: {aborted: f1}}
          f2: {action: nobody/here, transitions: {aborted: f1}}
"""


def test_a_region_whose_module_fails_at_once_is_retried_once_per_connect_timeout_and_spares_the_other(
    clock: VirtualClock,
) -> None:
    transport = EmbeddedTransport(clock)
    goals: list[tuple[str, float]] = []
    steady = BehaviourModule(transport.node("steady_node"))
    flaky = BehaviourModule(transport.node("flaky_node"))

    async def forever(ctx: GoalContext) -> None:
        goals.append(("s1", clock.monotonic()))
        await ctx.wait_forever()

    async def fails(ctx: GoalContext) -> None:
        goals.append(("f1", clock.monotonic()))
        raise Abort("no battery reading")

    steady.serve("steady_node/run", forever)
    flaky.serve("flaky_node/run", fails)
    controller = Controller(transport.node("cyborg_controller"), parse_config(FLAKY_REGION).machine)
    controller.start()
    clock.run(clock.sleep(4.5))
    assert [g for g, _ in goals].count("s1") == 1, "the steady region keeps its one goal"
    tries = [at for g, at in goals if g == "f1"]
    assert len(tries) == 5  # at 0, 1, 2, 3 and 4 s
    assert all(b - a >= 1.0 for a, b in itertools.pairwise(tries))
    assert controller.stats.retries_delayed == 5  # each failure, the last one still waiting
