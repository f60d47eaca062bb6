"""The controller's state machine at run time (thesis 6.1 and 8.1).

Modules publish event names on ``/cyborg_controller/register_event``. If an
event is a transition of the active state (or of a superstate around it), the
controller cancels the active module's goal, waits for the acknowledgement (or
the preempt timeout), then enters the next state: it sets ``/state_resources``,
publishes the change on ``/cyborg_controller/state_change`` and sends the goal
to the next module. Only then is another event looked at, so two modules are
never in control at once. A module's result becomes the event ``succeeded`` or
``aborted``. A result that leads back into the same state re-enters it at most
once per connect timeout, so a module that rejects every goal does not get a
flood of them. Everything is driven by messages; nothing polls.

In a parallel state (:mod:`cyborg.controller.regions`) every region's module has a goal at
once. Entering it starts them all; an event moves the regions that take it (each cancelled
concurrently, then each sent its new goal, highest priority first) or leaves the parallel
state, cancelling every region concurrently under the one preempt timeout. Each region's
change is published on ``state_change`` (from its previous leaf to its new one), the
arbitrated resources are written to ``/state_resources`` (so gatekeepers pass the
highest-priority holder) and the muted holders are published on ``/cyborg_controller/muted``.
Events are still handled one at a time: a module's result and an event that arrive together
are taken in the order they were queued, so the outcome never depends on thread timing.

Events from the topic wait in an :class:`~cyborg.controller.intake.EventIntake`: bounded by
size and by age (``timeouts.event_age``), each sender in its own line, the lines taking turns,
so a flood from one sender neither makes the robot replay a minute of stale events nor drops a
person's event. Drops are counted (``events_overflow``, ``events_stale``,
``events_superseded``) and logged once per burst and then as one summary every DROP_REPORT_PERIOD seconds.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import enum
import json
import logging
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

from cyborg.controller.intake import DropCounter, DropReason, EventIntake, QueuedEvent
from cyborg.controller.machine import ABORTED, SUCCEEDED, MachineSpec
from cyborg.controller.regions import Mute, Regions
from cyborg.transport import topics
from cyborg.transport.base import ActionClient, ClientGoalHandle, GoalStatus, MessageInfo, Node
from cyborg.transport.messages import (
    StateMachineAction,
    StateMachineFeedback,
    StateMachineGoal,
    StateMachineResult,
    String,
    SystemState,
)

log = logging.getLogger(__name__)

START_EVENT = "start"
DROP_REPORT_PERIOD = 10.0  # seconds between two summaries of dropped events while they are dropped

_Handle = ClientGoalHandle[StateMachineGoal, StateMachineResult, StateMachineFeedback]


class Phase(enum.Enum):
    """What the controller is doing right now."""

    STOPPED = "stopped"
    ENTERING = "entering"  # connecting to the next module and sending its goal
    ACTIVE = "active"  # a module is in control
    HANDING_OVER = "handing_over"  # waiting for the active module to acknowledge a cancel


class EventSource(enum.Enum):
    TOPIC = "topic"
    MODULE = "module"  # the active module's result: succeeded / aborted


@dataclass
class ControllerStats:
    """Counters a user can read (the dashboard and `cyborg status` show them)."""

    events_received: int = 0
    events_invalid: int = 0
    events_overflow: int = 0
    events_stale: int = 0
    events_superseded: int = 0
    handovers: int = 0
    preempt_timeouts: int = 0
    connect_failures: int = 0
    succeeded_fallbacks: int = 0
    retries_delayed: int = 0
    resource_grants: int = 0
    """In parallel states: resources granted to a region's node, counted at each configuration entered."""
    resource_mutes: int = 0
    """In parallel states: region nodes muted because a higher-priority region holds their resource."""


@dataclass(frozen=True)
class _Event:
    name: str
    source: EventSource
    goal_seq: int = 0
    deferred: bool = False  # a result re-entering its own state, held back for the connect timeout


@dataclass
class _Slot:
    """One region of the active parallel state: its leaf and its module's goal."""

    leaf: str
    seq: int = 0  # 0: no goal whose result counts
    goal: _Handle | None = None
    sent_at: float = 0.0


class Controller:
    """Runs a :class:`MachineSpec` against the modules' action servers."""

    def __init__(self, node: Node, machine: MachineSpec, *, event_queue_size: int = 100) -> None:
        self.node = node
        self.machine = machine
        self.stats = ControllerStats()
        self.phase = Phase.STOPPED
        self.active_state: str | None = None
        self.previous_state = ""
        self.last_event = ""
        self._intake = EventIntake(event_queue_size, machine.timeouts.event_age)
        self._results: deque[tuple[int, _Event]] = deque()  # module outcomes, by arrival order
        self._arrivals = 0  # arrival order of what is queued: results and topic events alike
        self._drops = DropCounter(DROP_REPORT_PERIOD)
        self._drop_report: asyncio.TimerHandle | None = None
        self._wakeup: asyncio.Event | None = None
        self._clients: dict[
            str, ActionClient[StateMachineGoal, StateMachineResult, StateMachineFeedback]
        ] = {}
        self._goal: _Handle | None = None
        self._goal_seq = 0
        self._goal_sent_at = 0.0
        self.deadline: float | None = None
        """While a handover waits on a module (an acknowledgement, a server, a retry): the clock's
        monotonic time by which it goes on whatever the module does; None otherwise. The loop
        watchdog of an in-process robot reads it (from its thread) to stop a module that blocks the
        loop past it."""
        self._task: asyncio.Task[None] | None = None
        self._state_pub = node.publisher(topics.STATE_CHANGE, SystemState, latch=True)
        self.regions = Regions(machine)
        self._slots: list[_Slot] | None = None  # in a parallel state: one per region, by priority
        self.mutes: list[Mute] = []
        self._mutes_pub = (
            node.publisher(topics.RESOURCE_MUTES, String, latch=True) if self.regions.parallels else None
        )
        self.last_feedback_at: dict[str, float] = {}  # action server -> clock.now() of its last feedback
        self._listeners: list[Callable[[SystemState], None]] = []
        node.subscribe(topics.REGISTER_EVENT, String, self._on_event_message, queue_size=event_queue_size)

    # --- public API -------------------------------------------------------------------

    def start(self) -> asyncio.Task[None]:
        """Enter the initial state and start handling events (runs on the clock's loop)."""
        if self._task is None:
            self._wakeup = asyncio.Event()
            self._task = self.node.clock.loop.create_task(self._run(), name="controller")
            self._task.add_done_callback(self._on_task_done)
        return self._task

    def close(self) -> None:
        """Stop handling events; the module in control keeps its goal (the robot is being stopped)."""
        self._stop_drop_reports()
        if self._task is not None and not self._task.done():
            self._task.cancel()

    def _on_task_done(self, task: asyncio.Task[None]) -> None:
        if not task.cancelled() and (error := task.exception()) is not None:
            log.critical(
                "the controller stopped in state %s: %r; the robot changes state no more; "
                "fix: restart cyborg_controller, and report this error",
                self.active_state,
                error,
                exc_info=error,
            )

    async def stop(self) -> None:
        self.phase = Phase.STOPPED
        self._stop_drop_reports()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        if self._goal is not None and not self._goal.status.is_terminal:
            self._goal.cancel()
        for slot in self._slots or ():
            if slot.goal is not None and not slot.goal.status.is_terminal:
                slot.goal.cancel()
        self.phase = Phase.STOPPED

    def add_state_listener(self, listener: Callable[[SystemState], None]) -> None:
        """Called synchronously on every state change (in-process observers such as the dashboard)."""
        self._listeners.append(listener)

    def valid_events(self) -> dict[str, str]:
        if self._slots is not None:
            merged: dict[str, str] = {}
            for slot in self._slots:
                for event, target in self.machine.transitions_of(slot.leaf).items():
                    merged.setdefault(event, target)
            return merged
        return self.machine.transitions_of(self.active_state) if self.active_state else {}

    @property
    def active_states(self) -> tuple[str, ...]:
        """The active leaves: one, or in a parallel state one per region, highest priority first."""
        if self._slots is not None:
            return tuple(slot.leaf for slot in self._slots)
        return (self.active_state,) if self.active_state else ()

    def active_regions(self) -> dict[str, str]:
        """In a parallel state, region -> its active leaf (highest priority first); else empty."""
        return (
            {self.regions.region_of(leaf) or leaf: leaf for leaf in self.active_states} if self._slots else {}
        )

    @property
    def goal_status(self) -> GoalStatus | None:
        return self._goal.status if self._goal is not None else None

    # --- event intake -----------------------------------------------------------------

    def _on_event_message(self, message: String, info: MessageInfo) -> None:
        self.stats.events_received += 1
        name = message.data.strip()
        idle_queue = self.phase is Phase.ACTIVE and not self._intake and not self._results
        if idle_queue and (
            self.active_state is None
            or (
                self.machine.lookup(self.active_state, name) is None
                if self._slots is None
                else not self.regions.takes(self.active_states, name)
            )
        ):
            # Fast path: nothing waits, so whether the event matters is decided at once.
            self._drop_invalid(name, info.sender)
            return
        self._arrivals += 1
        event = QueuedEvent(name, info.sender, self.node.clock.monotonic(), self._arrivals)
        dropped = self._intake.offer(event)
        if dropped is not None:
            self._dropped(dropped, DropReason.OVERFLOW)
        if dropped is not event and self._wakeup is not None:
            self._wakeup.set()

    def _dropped(self, event: QueuedEvent, reason: DropReason) -> None:
        if reason is DropReason.OVERFLOW:
            self.stats.events_overflow += 1
        elif reason is DropReason.STALE:
            self.stats.events_stale += 1
        else:
            self.stats.events_superseded += 1
        if not self._drops.note(reason, event.sender):
            return
        why = {
            DropReason.OVERFLOW: f"{self._intake.size} events already queued, the limit",
            DropReason.STALE: f"it waited {self.node.clock.monotonic() - event.received_at:.1f} s, "
            f"over the limit of {self._intake.max_age:g} s (timeouts.event_age)",
            DropReason.SUPERSEDED: "a newer event of another sender was taken before it",
        }[reason]
        log.warning(
            "event %r from %s dropped: %s; events come faster than the robot takes them: further "
            "drops are counted (events_overflow, events_stale, events_superseded) and summed up every %g s",
            event.name,
            event.sender,
            why,
            DROP_REPORT_PERIOD,
        )
        self._drop_report = self.node.clock.call_later(DROP_REPORT_PERIOD, self._report_drops)

    def _report_drops(self) -> None:
        self._drop_report = None
        summary = self._drops.summary()
        if summary is not None:
            log.warning(summary)
            self._drop_report = self.node.clock.call_later(DROP_REPORT_PERIOD, self._report_drops)

    def _stop_drop_reports(self) -> None:
        if self._drop_report is not None:
            self._drop_report.cancel()
            self._drop_report = None

    def _share_transitions(self) -> None:
        """Each state's events in a parameter, for tools that send events from outside."""
        transitions = {name: sorted(self.machine.transitions_of(name)) for name in self.machine.states}
        try:
            self.node.set_param(topics.TRANSITIONS_PARAM, transitions)
        except Exception as exc:  # a master away at start: the tools then cannot tell, nothing else
            log.warning("could not share the transitions in %s: %s", topics.TRANSITIONS_PARAM, exc)

    def _drop_invalid(self, name: str, sender: str) -> None:
        self.stats.events_invalid += 1
        log.debug("event %r from %s is no transition of %s; dropped", name, sender, self.active_state)

    def _push(self, event: _Event) -> None:
        self._arrivals += 1
        self._results.append((self._arrivals, event))
        if self._wakeup is not None:
            self._wakeup.set()

    def _next_event(self) -> _Event | None:
        """A module's outcome or the topic's next event by turn (stale ones dropped), whichever
        was queued first: so a result and an event that arrive together are taken in arrival order."""
        topic_first = self._intake.next_order()
        if self._results and (topic_first is None or self._results[0][0] < topic_first):
            return self._results.popleft()[1]
        queued, dropped = self._intake.take(self.node.clock.monotonic())
        for event, reason in dropped:
            self._dropped(event, reason)
        return None if queued is None else _Event(queued.name, EventSource.TOPIC)

    def _on_goal_done(self, handle: _Handle, seq: int) -> None:
        if self._slots is not None:
            if self.phase is not Phase.STOPPED and any(slot.seq == seq for slot in self._slots):
                self._push(
                    _Event(
                        SUCCEEDED if handle.status is GoalStatus.SUCCEEDED else ABORTED,
                        EventSource.MODULE,
                        seq,
                    )
                )
            return
        if seq != self._goal_seq or self.phase in (Phase.HANDING_OVER, Phase.STOPPED):
            return
        status = handle.status
        event = SUCCEEDED if status is GoalStatus.SUCCEEDED else ABORTED
        if status is not GoalStatus.SUCCEEDED:
            log.info(
                "module of %s ended %s (%s): event %r",
                self.active_state,
                status.name,
                handle.text or "no reason given",
                event,
            )
        self._push(_Event(event, EventSource.MODULE, seq))

    # --- the loop -----------------------------------------------------------------------

    async def _run(self) -> None:
        assert self._wakeup is not None
        self._share_transitions()
        await self._enter(self.machine.enter(self.machine.initial), START_EVENT)
        while True:
            event = self._next_event()
            while event is None:
                self._wakeup.clear()
                await self._wakeup.wait()
                event = self._next_event()
            await self._handle(event)

    async def _handle(self, event: _Event) -> None:
        assert self.active_state is not None
        if self._slots is not None:
            await self._handle_in_parallel(self._slots, event)
            return
        if event.source is EventSource.MODULE and event.goal_seq != self._goal_seq:
            return  # outcome of a goal we already left
        target = self.machine.lookup(self.active_state, event.name)
        name = event.name
        if target is None and event.source is EventSource.MODULE:
            self.stats.succeeded_fallbacks += 1
            log.info("state %s has no %r transition; falling back to 'aborted'", self.active_state, name)
            target = self.machine.lookup(self.active_state, ABORTED)
        if target is None:
            self._drop_invalid(name, "queue")
            return
        if event.source is EventSource.TOPIC:
            await self._preempt_active()
        elif target == self.active_state and await self._hold_retry(target, name):
            return  # an event came in while waiting to re-enter: it decides where to go
        await self._enter(target, name)

    async def _hold_retry(self, state: str, event: str) -> bool:
        """A module's result leads back into its own state: re-enter at most once per connect timeout.

        Without this, a module that rejects or aborts every goal at once would be sent goal
        after goal as fast as the transport carries them. Returns True if a valid event
        arrived while waiting; that event is then handled instead of re-entering.
        """
        assert self._wakeup is not None
        clock = self.node.clock
        deadline = self._goal_sent_at + self.machine.timeouts.connect
        if deadline <= clock.monotonic():
            return False
        self.stats.retries_delayed += 1
        log.warning(
            "module of %s ended (%r) %.2f s after its goal; re-entering %s in %.2f s unless an event comes first",
            state,
            event,
            clock.monotonic() - self._goal_sent_at,
            state,
            deadline - clock.monotonic(),
        )
        self.phase = Phase.ENTERING
        wanted = set(self.machine.transitions_of(state))
        while not self._intake.has(wanted):
            remaining = deadline - clock.monotonic()
            if remaining <= 0:
                return False
            self._wakeup.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._wakeup.wait(), remaining)
        return True

    async def _preempt_active(self) -> None:
        goal = self._goal
        if goal is None or goal.status.is_terminal:
            return
        self.phase = Phase.HANDING_OVER
        goal.cancel()
        with self._deadline(self.machine.timeouts.preempt):
            finished = await self._finished_within(goal, self.machine.timeouts.preempt)
        if not finished:
            self.stats.preempt_timeouts += 1
            log.warning(
                "module of %s did not acknowledge the cancel within %.1f s; handing over anyway",
                self.active_state,
                self.machine.timeouts.preempt,
            )

    async def _finished_within(self, goal: _Handle, timeout: float) -> bool:
        """Wait until ``goal`` is finished (True) or ``timeout`` clock seconds have passed (False).

        The handover's wait for the acknowledgement: the controller goes on in the loop turn after
        the one that took the result (``asyncio.wait_for`` would run the wait in a task of its own
        and go on three turns later).
        """
        if goal.status.is_terminal:
            return True
        woken = self.node.clock.loop.create_future()

        def wake(*_: object) -> None:
            if not woken.done():
                woken.set_result(None)

        goal.add_done_callback(wake)
        timer = self.node.clock.call_later(timeout, wake)
        try:
            await woken
        finally:
            timer.cancel()
        return goal.status.is_terminal

    async def _enter(self, state: str, event: str) -> None:
        """Enter ``state``; on a connection failure follow its 'aborted' transition."""
        while True:
            if self.regions.parallel_of(state) is not None:
                await self._enter_parallel(self.regions.configuration(state), event)
                return
            self.phase = Phase.ENTERING
            previous = self.active_state or ""
            self._goal_seq += 1
            self._goal = None
            self.previous_state, self.active_state, self.last_event = previous, state, event
            self.stats.handovers += 1
            try:  # (over ROS a master that does not answer gets it when it is back)
                self.node.set_param(topics.STATE_RESOURCES_PARAM, self.machine.resources_of(state))
            except Exception:
                log.exception(
                    "could not set %s for state %s; entering it anyway (gatekeepers still read the "
                    "previous state's resources)",
                    topics.STATE_RESOURCES_PARAM,
                    state,
                )
            self._announce(SystemState(event=event, from_system_state=previous, to_system_state=state))
            if (handle := await self._send_goal(state, event, previous, self._goal_seq)) is not None:
                self._goal = handle
                self._goal_sent_at = self.node.clock.monotonic()
                self.phase = Phase.ACTIVE
                return
            self.stats.connect_failures += 1
            fallback = self.machine.lookup(state, ABORTED)
            assert fallback is not None  # validation guarantees an 'aborted' transition
            state, event = fallback, ABORTED
            if fallback == self.active_state:
                # Retrying the same missing server: wait a bit instead of spinning.
                await self.node.clock.sleep(self.machine.timeouts.connect)

    @contextlib.contextmanager
    def _deadline(self, seconds: float) -> Iterator[None]:
        """Publish :attr:`deadline` while a handover waits at most ``seconds`` on a module."""
        self.deadline = self.node.clock.monotonic() + seconds
        try:
            yield
        finally:
            self.deadline = None

    def _on_feedback(self, action: str) -> None:
        self.last_feedback_at[action.lstrip("/")] = self.node.clock.now()

    def _announce(self, change: SystemState) -> None:
        """Publish a state change and tell this process's listeners (one that raises is logged)."""
        self._state_pub.publish(change)
        for listener in self._listeners:
            try:
                listener(change)
            except Exception:
                log.exception("state listener failed")

    async def _send_goal(self, state: str, event: str, previous: str, seq: int) -> _Handle | None:
        action = self.machine.states[state].action
        assert action is not None
        client = self._clients.get(action)
        if client is None:
            client = self._clients[action] = self.node.action_client(action, StateMachineAction)
        if not client.server_available():
            connect = self.machine.timeouts.connect
            with self._deadline(connect):
                offered = await client.wait_for_server(connect)
            if not offered:
                log.warning(
                    "no action server %s for state %s within %.1f s: taking 'aborted'",
                    action,
                    state,
                    connect,
                )
                return None
        goal = StateMachineGoal(previous_state=previous, event=event, current_state=state)
        handle = client.send_goal(goal, on_feedback=lambda feedback: self._on_feedback(action))
        handle.add_done_callback(lambda h: self._on_goal_done(h, seq))
        return handle

    # --- parallel states ----------------------------------------------------------------

    async def _handle_in_parallel(self, slots: list[_Slot], event: _Event) -> None:
        leaves = tuple(slot.leaf for slot in slots)
        index: int | None = None
        if event.source is EventSource.MODULE:
            index = next((i for i, slot in enumerate(slots) if slot.seq == event.goal_seq), None)
            if index is None:
                return  # outcome of a goal we already left
        source = None if index is None else leaves[index]
        step = self.regions.step(leaves, event.name, source)
        if step is None and source is not None:
            self.stats.succeeded_fallbacks += 1
            log.info("state %s has no %r transition; falling back to 'aborted'", source, event.name)
            step = self.regions.step(leaves, ABORTED, source)
        if step is None:
            self._drop_invalid(event.name, "queue")
            return
        if step.whole:
            self.phase = Phase.HANDING_OVER
            await self._cancel_slots(slots, range(len(slots)))
            self._slots = None
            self._share_mutes([])
            if len(step.leaves) > 1:
                await self._enter_parallel(step.leaves, event.name)
            else:
                await self._enter(step.leaves[0], event.name)
            return
        if index is not None and step.leaves[index] == source and not event.deferred:
            wait = slots[index].sent_at + self.machine.timeouts.connect - self.node.clock.monotonic()
            if wait > 0:  # as _hold_retry: a module failing at once is not sent goal after goal
                self.stats.retries_delayed += 1
                log.warning("module of %s ended (%r); re-entering it in %.2f s", source, event.name, wait)
                self.node.clock.call_later(wait, self._push, dataclasses.replace(event, deferred=True))
                return
        self.phase = Phase.HANDING_OVER
        await self._cancel_slots(slots, step.moved)
        previous = {i: leaves[i] for i in step.moved}
        for i in step.moved:
            slots[i].leaf = step.leaves[i]
        self.previous_state, self.active_state, self.last_event = (
            leaves[step.moved[0]],
            step.leaves[0],
            event.name,
        )
        self.stats.handovers += 1
        await self._start_slots(slots, step.moved, event.name, previous)

    async def _enter_parallel(self, leaves: tuple[str, ...], event: str) -> None:
        """Enter a parallel state's configuration: every region's module gets its goal."""
        self.phase = Phase.ENTERING
        previous = self.active_state or ""
        self._goal = None
        slots = self._slots = [_Slot(leaf) for leaf in leaves]
        self.previous_state, self.active_state, self.last_event = previous, leaves[0], event
        self.stats.handovers += 1
        await self._start_slots(slots, range(len(slots)), event, dict.fromkeys(range(len(slots)), previous))

    async def _start_slots(
        self, slots: list[_Slot], indices: Iterable[int], event: str, previous: dict[int, str]
    ) -> None:
        """Share the resources, announce each region's change, then send the goals (all at once)."""
        indices = list(indices)
        leaves = tuple(slot.leaf for slot in slots)
        granted, mutes = self.regions.arbitrate(leaves)
        self.stats.resource_grants += len(self.regions.holders(leaves))
        self.stats.resource_mutes += len(mutes)
        try:
            self.node.set_param(topics.STATE_RESOURCES_PARAM, granted)
        except Exception:
            log.exception("could not set %s for %s; entering anyway", topics.STATE_RESOURCES_PARAM, leaves)
        self._share_mutes(mutes)
        for i in indices:
            self._goal_seq += 1
            slots[i].seq, slots[i].goal = self._goal_seq, None
            self._announce(
                SystemState(event=event, from_system_state=previous[i], to_system_state=slots[i].leaf)
            )
        sends = [self._send_goal(slots[i].leaf, event, previous[i], slots[i].seq) for i in indices]
        sent = [await sends[0]] if len(sends) == 1 else await asyncio.gather(*sends)
        now = self.node.clock.monotonic()
        for i, handle in zip(indices, sent, strict=True):
            slots[i].sent_at = now
            if handle is None:
                self.stats.connect_failures += 1
                self._push(_Event(ABORTED, EventSource.MODULE, slots[i].seq))
            else:
                slots[i].goal = handle
        self.phase = Phase.ACTIVE

    async def _cancel_slots(self, slots: list[_Slot], indices: Iterable[int]) -> None:
        """Cancel these regions' goals at once; wait for them all, at most the preempt timeout."""
        cancelled: list[tuple[str, _Handle]] = []
        for i in indices:
            slot = slots[i]
            slot.seq = 0  # its result no longer counts
            if slot.goal is not None and not slot.goal.status.is_terminal:
                slot.goal.cancel()
                cancelled.append((slot.leaf, slot.goal))
        if not cancelled:
            return
        preempt = self.machine.timeouts.preempt
        with self._deadline(preempt):
            if len(cancelled) == 1:
                await self._finished_within(cancelled[0][1], preempt)
            else:
                waits = [asyncio.ensure_future(goal.wait()) for _, goal in cancelled]
                for task in (await asyncio.wait(waits, timeout=preempt))[1]:
                    task.cancel()
        for leaf, goal in cancelled:
            if not goal.status.is_terminal:
                self.stats.preempt_timeouts += 1
                log.warning(
                    "module of %s did not acknowledge the cancel within %.1f s; handing over anyway",
                    leaf,
                    preempt,
                )

    def _share_mutes(self, mutes: list[Mute]) -> None:
        had, self.mutes = self.mutes, mutes
        if self._mutes_pub is None or (self._slots is None and not had):
            return
        self._mutes_pub.publish(
            String(json.dumps({"states": list(self.active_states), "muted": [m.as_dict() for m in mutes]}))
        )
