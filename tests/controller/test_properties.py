"""Property-based tests: random events against modules that misbehave in random ways.

Whatever happens, exactly one state is active, at most one module goal is in
control (a goal whose cancel was requested no longer counts: the controller
has taken control back), and every state change is published once, in order.
"""

from __future__ import annotations

import enum
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cyborg.controller.config import parse_config
from cyborg.controller.runtime import Controller
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, Node, ServerGoalHandle
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import StateMachineAction, StateMachineResult, String, SystemState

STATES = ["idle", "a", "b", "c"]
MACHINE = """
timeouts: {connect: 0.3, preempt: 0.2}
states:
  idle: {action: m_idle/run, transitions: {to_a: a, to_b: b, aborted: idle}}
  a: {action: m_a/run, transitions: {to_b: b, to_c: c, succeeded: idle, aborted: idle}}
  b: {action: m_b/run, transitions: {to_a: a, to_c: c, aborted: idle}}
  group:
    transitions: {to_idle: idle, aborted: idle}
    states:
      c: {action: m_c/run, transitions: {to_a: a, succeeded: b}}
"""
EVENTS = ["to_a", "to_b", "to_c", "to_idle", "bogus", "succeeded", "aborted"]


class Behaviour(enum.Enum):
    SUCCEEDS = "succeeds"
    ABORTS = "aborts"
    RUNS_UNTIL_CANCELLED = "runs"
    IGNORES_CANCEL = "ignores_cancel"
    NEVER_ANSWERS = "never_answers"
    DISAPPEARS = "disappears"


class RandomModule:
    def __init__(self, node: Node, action: str, behaviour: Behaviour, delay: float, world: World) -> None:
        self.node = node
        self.behaviour = behaviour
        self.delay = delay
        self.world = world
        self.gone = False
        node.action_server(action, StateMachineAction, self.on_goal, self.on_cancel)

    def on_goal(self, handle: ServerGoalHandle[Any, Any, Any]) -> None:
        self.world.goals.append((self, handle))
        if self.behaviour is Behaviour.NEVER_ANSWERS:
            return
        handle.accept()
        self.world.check("accept")
        clock = self.node.clock
        if self.behaviour is Behaviour.SUCCEEDS:
            clock.call_later(self.delay, self.finish, handle, True)
        elif self.behaviour is Behaviour.ABORTS:
            clock.call_later(self.delay, self.finish, handle, False)
        elif self.behaviour is Behaviour.DISAPPEARS:
            clock.call_later(self.delay, self.disappear)

    def disappear(self) -> None:
        self.gone = True
        self.node.shutdown()

    def finish(self, handle: ServerGoalHandle[Any, Any, Any], ok: bool) -> None:
        if handle.status in (GoalStatus.ACTIVE, GoalStatus.PREEMPTING):
            (handle.succeed if ok else handle.abort)(StateMachineResult())

    def on_cancel(self, handle: ServerGoalHandle[Any, Any, Any]) -> None:
        if self.behaviour not in (Behaviour.IGNORES_CANCEL, Behaviour.NEVER_ANSWERS):
            handle.canceled()


class World:
    def __init__(self) -> None:
        self.goals: list[tuple[RandomModule, ServerGoalHandle[Any, Any, Any]]] = []
        self.published: list[tuple[str, str, str]] = []
        self.entered: list[tuple[str, str, str]] = []
        self.violations: list[str] = []

    def in_control(self) -> int:
        return sum(
            1
            for module, goal in self.goals
            if not module.gone and goal.status is GoalStatus.ACTIVE and not goal.cancel_requested
        )

    def check(self, when: str) -> None:
        if self.in_control() > 1:
            self.violations.append(f"{self.in_control()} goals in control at {when}")


behaviours = st.sampled_from(list(Behaviour))
delays = st.floats(min_value=0.01, max_value=2.0)
steps = st.lists(st.tuples(st.sampled_from(EVENTS), st.floats(min_value=0.0, max_value=1.0)), max_size=25)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(module_behaviours=st.tuples(*[st.tuples(behaviours, delays) for _ in STATES]), script=steps)
def test_random_events_keep_the_machine_consistent(
    module_behaviours: tuple[tuple[Behaviour, float], ...], script: list[tuple[str, float]]
) -> None:
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    world = World()
    for state, (behaviour, delay) in zip(STATES, module_behaviours, strict=True):
        RandomModule(transport.node(f"m_{state}"), f"m_{state}/run", behaviour, delay, world)
    observer = transport.node("observer")
    observer.subscribe(
        topics.STATE_CHANGE,
        SystemState,
        lambda m, i: world.published.append((m.from_system_state, m.event, m.to_system_state)),
        queue_size=1000,
    )
    events = observer.publisher(topics.REGISTER_EVENT, String)
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)

    def on_change(m: SystemState) -> None:
        world.entered.append((m.from_system_state, m.event, m.to_system_state))
        world.check(f"entering {m.to_system_state}")
        if controller.active_state not in STATES:
            world.violations.append(f"active state {controller.active_state!r}")

    controller.add_state_listener(on_change)
    controller.start()

    async def main() -> None:
        await clock.sleep(0.05)
        for event, gap in script:
            events.publish(String(event))
            await clock.sleep(gap)
        await clock.sleep(3.0)

    try:
        clock.run(main())
    finally:
        clock.close()
    assert world.violations == []
    assert world.published == world.entered, "every state change is published exactly once, in order"
    for previous, current in zip(world.published, world.published[1:], strict=False):
        assert current[0] == previous[2], f"change {current} does not follow {previous}"
    assert world.published[0] == ("", "start", "idle")
