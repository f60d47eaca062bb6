"""Re-run the controller alone against what a recording made over ROS says came into it.

A recording of a launch (ROS 1 or ROS 2, real time) cannot re-run the whole robot: its modules
did their work at the pace of the world. What came into the *controller* is in the recording,
though: every event sent to it (``/cyborg/events``, each at its nanosecond) and every module's
outcome (a state change on ``succeeded`` or ``aborted`` that no sent event of that name explains).
:func:`rerun_controller` runs the real :class:`~cyborg.controller.runtime.Controller` on the
recorded state machine (or another: a what-if) in one process, in virtual time from the
recording's start, with a stand-in server for each state's action that takes every goal, gives
it up at once when preempted, and ends it with the recorded outcome at its recorded time. Its
state changes are then compared with the recorded ones (:func:`first_state_difference`): the
controller's decisions, as AdvantageKit replays a robot's logic on its logged inputs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from cyborg.controller.machine import ABORTED, SUCCEEDED, MachineSpec
from cyborg.controller.runtime import Controller
from cyborg.observe.recording import Recording
from cyborg.observe.records import NS_PER_S, Record, readable_seconds, to_ns
from cyborg.sim.rerun import Difference
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, ServerGoalHandle
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import StateMachineAction, String, SystemState

__all__ = [
    "ControllerInput",
    "ControllerRerun",
    "controller_inputs",
    "first_state_difference",
    "rerun_controller",
]

OUTCOMES = (SUCCEEDED, ABORTED)
EVENT_SKEW_NS = 2 * NS_PER_S
"""How much later than the state change it caused an event may have been recorded."""
SETTLE_SECONDS = 1.0
"""Virtual seconds the re-run goes on after the last input (its last handover)."""


@dataclass(frozen=True)
class ControllerInput:
    """One thing that came into the controller: an ``event`` sent to it, or a module's ``outcome``
    (``name`` succeeded or aborted, ``state`` the state whose goal ended)."""

    t_ns: int
    kind: str
    name: str
    state: str = ""


@dataclass
class ControllerRerun:
    changes: list[Record]
    """The re-run's state changes, as state records (``t_ns`` from the recording's start)."""
    inputs: list[ControllerInput]

    @property
    def events(self) -> int:
        return sum(1 for each in self.inputs if each.kind == "event")

    @property
    def outcomes(self) -> int:
        return len(self.inputs) - self.events


def controller_inputs(recording: Recording) -> list[ControllerInput]:
    """The recorded events and module outcomes, in the order they came.

    The recorder hears an event from its sender and the state change it caused from the
    controller, on two connections: under load the state change may come first. An event
    recorded up to :data:`EVENT_SKEW_NS` after a state change of its name is taken as its cause
    (and sent again at the change's time); a state change on ``succeeded`` or ``aborted`` that no
    event explains is its module's outcome."""
    events = sorted((int(e["t_ns"]), str(e["event"])) for e in recording.events)
    used = [False] * len(events)
    inputs: list[ControllerInput] = []
    since: int | None = None  # the previous state change's time
    for record in recording.records:
        if record["type"] != "state":
            continue
        t_ns, event = int(record["t_ns"]), str(record["event"])
        cause = next(
            (
                index
                for index, (t, name) in enumerate(events)
                if not used[index]
                and name == event
                and (since is None or t >= since)
                and t <= t_ns + EVENT_SKEW_NS
            ),
            None,
        )
        if cause is not None:
            used[cause] = True
            inputs.append(ControllerInput(min(events[cause][0], t_ns), "event", event))
        elif event in OUTCOMES and record["from"]:
            inputs.append(ControllerInput(t_ns, "outcome", event, str(record["from"])))
        since = t_ns
    inputs.extend(
        ControllerInput(t, "event", name) for (t, name), done in zip(events, used, strict=True) if not done
    )
    inputs.sort(key=lambda each: each.t_ns)  # (stable: an event before an outcome of its instant)
    return inputs


class _StandIns:
    """A server for each action of the machine: takes every goal, gives it up when preempted,
    ends it when the recording says its module ended it."""

    def __init__(self, transport: EmbeddedTransport, machine: MachineSpec) -> None:
        node = transport.node("cyborg_rerun_modules")
        self.goals: dict[str, ServerGoalHandle[Any, Any, Any]] = {}
        for action in sorted({str(state.action) for state in machine.leaves()}):
            node.action_server(action, StateMachineAction, self._on_goal, self._on_cancel)

    def _on_goal(self, handle: ServerGoalHandle[Any, Any, Any]) -> None:
        handle.accept()
        self.goals[handle.goal.current_state] = handle

    def _on_cancel(self, handle: ServerGoalHandle[Any, Any, Any]) -> None:
        handle.canceled()

    def end(self, state: str, outcome: str) -> None:
        handle = self.goals.pop(state, None)
        if handle is None or handle.status is not GoalStatus.ACTIVE:
            return  # the re-run is elsewhere: the comparison says where
        if outcome == SUCCEEDED:
            handle.succeed()
        else:
            handle.abort(text="as recorded")


def rerun_controller(recording: Recording, machine: MachineSpec) -> ControllerRerun:
    """Run ``machine``'s controller alone on the recording's inputs, in virtual time."""
    inputs = controller_inputs(recording)
    clock = VirtualClock(start=recording.start_ns / NS_PER_S)
    transport = EmbeddedTransport(clock)
    changes: list[Record] = []
    try:
        controller = Controller(transport.node(topics.CONTROLLER_NODE), machine)
        stand_ins = _StandIns(transport, machine)
        sender = transport.node("cyborg_rerun").publisher(topics.REGISTER_EVENT, String)
        origin = clock.monotonic()

        def on_change(change: SystemState) -> None:
            t_ns = to_ns(clock.monotonic() - origin)
            changes.append(
                {
                    "t": readable_seconds(t_ns),
                    "t_ns": t_ns,
                    "type": "state",
                    "event": change.event,
                    "from": change.from_system_state,
                    "to": change.to_system_state,
                }
            )

        controller.add_state_listener(on_change)

        async def main() -> None:
            controller.start()
            for each in inputs:
                wait = origin + each.t_ns / NS_PER_S - clock.monotonic()
                if wait > 0:
                    await clock.sleep(wait)
                if each.kind == "event":
                    sender.publish(String(each.name))
                else:
                    stand_ins.end(each.state, each.name)
            await clock.sleep(SETTLE_SECONDS)
            await controller.stop()

        clock.run(main())
    finally:
        transport.shutdown()
        clock.close()
    return ControllerRerun(changes, inputs)


def first_state_difference(recorded: list[Record], rerun: list[Record]) -> Difference | None:
    """Where two runs' state changes (event, from, to) first differ; None if they are the same."""
    mine = [r for r in recorded if r["type"] == "state"]
    theirs = [r for r in rerun if r["type"] == "state"]

    def key(record: Record | None) -> tuple[str, str, str] | None:
        return None if record is None else (record["event"], record["from"], record["to"])

    for index in range(max(len(mine), len(theirs))):
        a = mine[index] if index < len(mine) else None
        b = theirs[index] if index < len(theirs) else None
        if key(a) != key(b):
            return Difference(index, a, b)
    return None
