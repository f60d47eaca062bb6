"""Property-based tests: random events against modules that misbehave in random ways.

What a user cares about, checked at every goal the controller sends:

* No two modules act at once: the controller never sends a new goal while an earlier
  goal is still ACTIVE or PREEMPTING on its module's side, unless it asked that goal to
  stop, waited the full preempt timeout and counted a preempt timeout for it (a module
  that ignores a cancel cannot be stopped, only given up on).
* Every published state change is backed by exactly one goal to that state's module,
  carrying the change's previous state, event and state; or, when the module's action
  server cannot be reached, by an ``aborted`` change that follows it.
* Every change follows the machine's transitions, and the changes form one chain.
"""

from __future__ import annotations

import enum
import itertools
from dataclasses import dataclass
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cyborg.app.config import parse_config
from cyborg.controller.machine import ABORTED, SUCCEEDED, MachineSpec
from cyborg.controller.runtime import Controller, Phase
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, Node, ServerGoalHandle
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import (
    StateMachineAction,
    StateMachineGoal,
    StateMachineResult,
    String,
    SystemState,
)

STATES = ["idle", "a", "b", "c"]
PREEMPT = 0.2
MACHINE = f"""
timeouts: {{connect: 0.3, preempt: {PREEMPT}}}
states:
  idle: {{action: m_idle/run, transitions: {{to_a: a, to_b: b, aborted: idle}}}}
  a: {{action: m_a/run, transitions: {{to_b: b, to_c: c, succeeded: idle, aborted: idle}}}}
  b: {{action: m_b/run, transitions: {{to_a: a, to_c: c, aborted: idle}}}}
  group:
    transitions: {{to_idle: idle, aborted: idle}}
    states:
      c: {{action: m_c/run, transitions: {{to_a: a, succeeded: b}}}}
"""
EVENTS = ["to_a", "to_b", "to_c", "to_idle", "bogus", "succeeded", "aborted"]
RUNNING = (GoalStatus.ACTIVE, GoalStatus.PREEMPTING)
MAX_GOALS = 300  # 25 events and retries at most once per connect timeout stay far below


class Outcome(enum.Enum):
    SUCCEEDS = "succeeds"
    ABORTS = "aborts"
    RUNS_UNTIL_CANCELLED = "runs"
    REJECTS = "rejects"
    NEVER_ANSWERS = "never_answers"  # neither accepts nor rejects, ignores cancels
    DISAPPEARS = "disappears"  # the node dies mid-goal
    ABSENT = "absent"  # no action server at all


class OnCancel(enum.Enum):
    PROMPT = "prompt"
    LATE = "late"  # acknowledges after cancel_delay, which may exceed the preempt timeout
    IGNORES = "ignores"


@dataclass
class ModuleGoal:
    module: RandomModule
    handle: ServerGoalHandle[Any, Any, Any]
    cancel_at: float | None = None


class RandomModule:
    def __init__(
        self,
        node: Node,
        action: str,
        outcome: Outcome,
        on_cancel: OnCancel,
        delay: float,
        cancel_delay: float,
        world: World,
    ) -> None:
        self.node = node
        self.outcome = outcome
        self.on_cancel_mode = on_cancel
        self.delay = delay
        self.cancel_delay = cancel_delay
        self.world = world
        self.gone = outcome is Outcome.ABSENT
        if not self.gone:
            node.action_server(action, StateMachineAction, self.on_goal, self.on_cancel)

    def on_goal(self, handle: ServerGoalHandle[Any, Any, Any]) -> None:
        self.world.goals[handle.goal_id] = ModuleGoal(self, handle)
        if len(self.world.goals) > MAX_GOALS:  # flooded: fail instead of spinning in virtual time
            self.world.violations.append(f"more than {MAX_GOALS} goals sent")
            self.disappear()
            return
        if self.outcome is Outcome.NEVER_ANSWERS:
            return
        if self.outcome is Outcome.REJECTS:
            handle.reject(StateMachineResult(), "busy")
            return
        handle.accept()
        clock = self.node.clock
        if self.outcome is Outcome.SUCCEEDS:
            clock.call_later(self.delay, self.finish, handle, True)
        elif self.outcome is Outcome.ABORTS:
            clock.call_later(self.delay, self.finish, handle, False)
        elif self.outcome is Outcome.DISAPPEARS:
            clock.call_later(self.delay, self.disappear)

    def disappear(self) -> None:
        self.gone = True
        self.node.shutdown()

    def finish(self, handle: ServerGoalHandle[Any, Any, Any], ok: bool) -> None:
        if handle.status in RUNNING:
            (handle.succeed if ok else handle.abort)(StateMachineResult())

    def on_cancel(self, handle: ServerGoalHandle[Any, Any, Any]) -> None:
        self.world.goals[handle.goal_id].cancel_at = self.node.clock.monotonic()
        if self.outcome is Outcome.NEVER_ANSWERS or self.on_cancel_mode is OnCancel.IGNORES:
            return
        if self.on_cancel_mode is OnCancel.PROMPT:
            handle.canceled()
        else:
            self.node.clock.call_later(self.cancel_delay, self.acknowledge_late, handle)

    @staticmethod
    def acknowledge_late(handle: ServerGoalHandle[Any, Any, Any]) -> None:
        if not handle.status.is_terminal:
            handle.canceled()


@dataclass(frozen=True)
class Change:
    previous: str
    event: str
    state: str
    reachable: bool  # was the state's action server there when the change was published?


class World:
    def __init__(self, clock: VirtualClock, modules: dict[str, RandomModule]) -> None:
        self.clock = clock
        self.modules = modules
        self.goals: dict[str, ModuleGoal] = {}
        self.sent: list[tuple[str, str, str, str]] = []  # (action, previous, event, state) as sent
        self.published: list[tuple[str, str, str]] = []
        self.entered: list[Change] = []
        self.given_up: set[str] = set()  # running goals the controller went past after a preempt timeout
        self.violations: list[str] = []
        self.controller: Controller | None = None

    def before_send(self, action: str, goal: StateMachineGoal) -> None:
        """Called synchronously when the controller sends a goal, before it leaves."""
        assert self.controller is not None
        now = self.clock.monotonic()
        self.sent.append((action, goal.previous_state, goal.event, goal.current_state))
        for goal_id, record in self.goals.items():
            if record.module.gone or record.handle.status not in RUNNING:
                continue
            if record.cancel_at is None:
                self.violations.append(
                    f"t={now:.3f}: goal to {goal.current_state} sent while goal {goal_id} runs, never cancelled"
                )
            elif now - record.cancel_at < PREEMPT - 1e-9:
                self.violations.append(
                    f"t={now:.3f}: goal to {goal.current_state} sent {now - record.cancel_at:.3f} s after "
                    f"cancelling still-running goal {goal_id}: before the {PREEMPT} s preempt timeout"
                )
            else:
                self.given_up.add(goal_id)
        if len(self.given_up) > self.controller.stats.preempt_timeouts:
            self.violations.append(
                f"t={now:.3f}: {len(self.given_up)} goals given up on, but only "
                f"{self.controller.stats.preempt_timeouts} preempt timeouts counted"
            )

    def on_change(self, message: SystemState) -> None:
        module = self.modules[message.to_system_state]
        reachable = not module.gone
        self.entered.append(
            Change(message.from_system_state, message.event, message.to_system_state, reachable)
        )


class SpyClient:
    """An action client that tells the world about each goal as it is sent."""

    def __init__(self, inner: Any, action: str, world: World) -> None:
        self._inner = inner
        self._action = action
        self._world = world

    def send_goal(self, goal: StateMachineGoal, **kw: Any) -> Any:
        self._world.before_send(self._action, goal)
        return self._inner.send_goal(goal, **kw)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)


def check_changes(world: World, machine: MachineSpec, controller: Controller) -> None:
    changes = world.entered
    assert [(c.previous, c.event, c.state) for c in changes] == world.published, (
        "every state change is published exactly once, in order"
    )
    assert (changes[0].previous, changes[0].event, changes[0].state) == ("", "start", "idle")
    for before, change in itertools.pairwise(changes):
        assert change.previous == before.state, f"{change} does not follow {before}"
        allowed = {machine.lookup(change.previous, change.event)}
        if change.event == SUCCEEDED:  # a module's success without a 'succeeded' transition
            allowed.add(machine.lookup(change.previous, ABORTED))
        assert change.state in allowed, f"{change} is no transition of the machine"
    sends = iter(world.sent)
    unreached = 0
    waiting = 0  # 1 if the last change's server is missing and the controller still waits or retries
    for i, change in enumerate(changes):
        action = machine.states[change.state].action
        expected = (action, change.previous, change.event, change.state)
        if change.reachable:
            assert next(sends, None) == expected, f"change {i} {change} has no goal of its own"
            continue
        unreached += 1
        if i + 1 < len(changes):  # the server was missing: 'aborted' follows, with no goal sent
            following = changes[i + 1]
            assert (following.previous, following.event) == (change.state, ABORTED), (
                f"after {change} to an unreachable server came {following}"
            )
        else:
            assert controller.phase is Phase.ENTERING, "still waiting for the missing server"
            unreached, waiting = unreached - 1, 1
    assert next(sends, None) is None, "a goal was sent without a state change"
    assert unreached <= controller.stats.connect_failures <= unreached + waiting


outcomes = st.sampled_from(list(Outcome))
cancel_modes = st.sampled_from(list(OnCancel))
delays = st.floats(min_value=0.01, max_value=2.0)
cancel_delays = st.floats(min_value=0.01, max_value=0.5)
module_specs = st.tuples(outcomes, cancel_modes, delays, cancel_delays)
steps = st.lists(st.tuples(st.sampled_from(EVENTS), st.floats(min_value=0.0, max_value=1.0)), max_size=25)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(specs=st.tuples(*[module_specs for _ in STATES]), script=steps)
def test_random_events_never_put_two_modules_in_control(
    specs: tuple[tuple[Outcome, OnCancel, float, float], ...], script: list[tuple[str, float]]
) -> None:
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    modules: dict[str, RandomModule] = {}
    world = World(clock, modules)
    for state, (outcome, on_cancel, delay, cancel_delay) in zip(STATES, specs, strict=True):
        modules[state] = RandomModule(
            transport.node(f"m_{state}"), f"m_{state}/run", outcome, on_cancel, delay, cancel_delay, world
        )
    observer = transport.node("observer")
    observer.subscribe(
        topics.STATE_CHANGE,
        SystemState,
        lambda m, i: world.published.append((m.from_system_state, m.event, m.to_system_state)),
        queue_size=1000,
    )
    events = observer.publisher(topics.REGISTER_EVENT, String)
    machine = parse_config(MACHINE).machine
    node = transport.node("cyborg_controller")
    make_client = node.action_client
    node.action_client = lambda name, action_type: SpyClient(make_client(name, action_type), name, world)  # type: ignore[method-assign, assignment, return-value]
    controller = world.controller = Controller(node, machine)
    controller.add_state_listener(world.on_change)
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
    check_changes(world, machine, controller)
