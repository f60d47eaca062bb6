"""A client of a robot running as ROS nodes (``cyborg event NAME --ros`` / ``--ros2``): the thesis's topics.

Each command joins the graph (ROS 1: at ``ROS_MASTER_URI``; ROS 2: its ``ROS_DOMAIN_ID``) as a
short-lived node ``cyborg_tool`` (ROS 1: in the process ``cyborg_tool_<pid>``), publishes on the
controller's topics exactly as ``rostopic pub`` / ``ros2 topic pub`` would (waiting first until
the listening nodes are connected, so nothing is lost), reads the state from the latched
``state_change`` and the emotion from the ``get_emotional_state`` service. ROS 2 has no master
to ask who listens: the tool waits up to CONNECT_TIMEOUT for discovery to show the listeners.
"""

from __future__ import annotations

import asyncio
import contextlib
import signal
from collections.abc import Callable, Coroutine
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, cast

from cyborg.errors import CyborgError, ServiceTimeoutError, ServiceUnavailableError, TransportError
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.clock import RealClock
from cyborg.transport.messages import (
    EmotionalFeedback,
    EmotionalState,
    EmotionalStateService,
    Message,
    String,
    SystemState,
)

if TYPE_CHECKING:
    from cyborg.run.middleware import Middleware

T = TypeVar("T")
CONNECT_TIMEOUT = 3.0  # seconds to wait for the listening nodes to connect, or for a latched message
DELIVERY_GRACE = 0.3  # seconds rospy's writer threads get before the node leaves the graph
DDS_TAKE_GRACE = 1.0  # ROS 2: seconds the listeners get to take an acknowledged message (see _publish)
DISCOVERY_SETTLE = 0.3  # ROS 2: seconds a topic's listeners stay the same before the tool publishes


class _GraphTransport(Protocol):
    """What the tool needs of a ROS transport beyond :class:`Transport`: who listens on a topic."""

    def subscribers_of(self, topic: str) -> list[str]: ...
    def subscription_endpoints(self, topic: str) -> int: ...


class RosLink:
    """One command's connection to a robot running as nodes of ``middleware`` (ROS 1 or ROS 2)."""

    def __init__(self, middleware: Middleware) -> None:
        self._clock = RealClock()
        self.middleware = middleware
        self._transport = middleware.tool_transport(self._clock)
        self._graph = cast(_GraphTransport, self._transport)
        self._node: Node = self._transport.node("cyborg_tool")
        self.delivered_to: list[str] | None = None
        """The nodes the last message reached (all the graph listed as listening), once sent."""

    def close(self) -> None:
        self._transport.close()
        self._clock.close()

    def _run(self, main: Coroutine[Any, Any, T]) -> T:
        return self._clock.run(main)

    async def _publish(self, topic: str, message: Message) -> None:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + CONNECT_TIMEOUT
        late = self.middleware.discovers_late
        listeners = self._graph.subscribers_of(topic)
        while late and not listeners and loop.time() < deadline:  # discovery takes a moment
            await asyncio.sleep(0.02)
            listeners = self._graph.subscribers_of(topic)
        if late:  # the first listeners seen may be a few of them: wait until no more appear
            settled = loop.time() + DISCOVERY_SETTLE
            while listeners and loop.time() < min(settled, deadline):
                await asyncio.sleep(0.02)
                seen = self._graph.subscribers_of(topic)
                if set(seen) != set(listeners):
                    listeners, settled = seen, loop.time() + DISCOVERY_SETTLE
        if not listeners:
            launch = " ".join(["cyborg launch", *self.middleware.node_arguments])
            raise CyborgError(
                f"no node listens on {topic}; fix: start the robot (`{launch}`) or check "
                f"{self.middleware.graph_setting}"
            )
        # Latched, so that a listener whose reader meets ours only after the message was sent
        # still gets it (ROS 2: a reader drops what a writer it has not yet discovered sends;
        # our subscriptions take a message once, whichever of their two halves brings it). The
        # tool waits for every listener the graph shows, then for each to acknowledge it.
        publisher = self._node.publisher(topic, type(message), latch=True)
        graph = self._graph

        def all_matched() -> bool:
            return publisher.subscriber_count() >= graph.subscription_endpoints(topic)

        while not all_matched() and loop.time() < deadline:
            await asyncio.sleep(0.01)
        publisher.publish(message)
        acknowledged = await asyncio.to_thread(publisher.wait_delivered, CONNECT_TIMEOUT)
        # A listener the graph showed meanwhile gets the latched message once it matches.
        while late and not all_matched() and loop.time() < deadline:
            await asyncio.sleep(0.01)
        if late:
            acknowledged = await asyncio.to_thread(publisher.wait_delivered, CONNECT_TIMEOUT)
        # ROS 1: rospy's writer threads have no acknowledgement. ROS 2: a reader that has the
        # message may not have taken it yet, and a writer that leaves takes its untaken samples
        # along (a loaded machine lost one in 0.3 s: the listener's executor had not run yet).
        await asyncio.sleep(DDS_TAKE_GRACE if late else DELIVERY_GRACE)
        listeners = sorted(set(listeners) | set(graph.subscribers_of(topic)))
        self.delivered_to = listeners
        if not acknowledged or not all_matched():
            raise CyborgError(
                f"{topic}: not every listener took the message (reached {publisher.subscriber_count()} "
                f"of {graph.subscription_endpoints(topic)} subscriptions of {', '.join(listeners)}); "
                f"fix: check that those nodes run and share {self.middleware.graph_setting}, and "
                "send it again"
            )

    async def _see_parameters(self) -> None:
        """Wait (up to CONNECT_TIMEOUT) until the controller's parameters can be read: on ROS 2 a
        fresh node may not see their home yet, and a read before that finds nothing."""
        await self.middleware.see_parameters(self._transport, CONNECT_TIMEOUT)

    # --- the commands -------------------------------------------------------------------------

    def send_event(self, name: str) -> bool | None:
        """Send it; whether it is a transition of the current state (None if that is not known)."""
        valid = self._run(self._valid_events())
        self._run(self._publish(topics.REGISTER_EVENT, String(name)))
        return None if valid is None else name in valid

    async def _valid_events(self) -> set[str] | None:
        """The current state's events, from the latched state change and the controller's parameter.

        The state change first: once it has come, ROS 2's discovery knows the controller's process,
        which hosts the parameters (asked earlier, a fresh node may not see them yet)."""
        current: list[str] = []
        subscription = self._node.subscribe(
            topics.STATE_CHANGE, SystemState, lambda m, i: current.append(m.to_system_state)
        )
        try:
            deadline = asyncio.get_running_loop().time() + CONNECT_TIMEOUT
            while not current and asyncio.get_running_loop().time() < deadline:
                await asyncio.sleep(0.02)  # latched: it comes as soon as we are connected
        finally:
            subscription.unsubscribe()
        await self._see_parameters()
        try:
            transitions = self._node.get_param(topics.TRANSITIONS_PARAM, None)
        except TransportError:
            return None
        if not isinstance(transitions, dict):
            return None  # a controller that does not share them
        events = transitions.get(current[-1]) if current else None
        return set(events) if isinstance(events, list) else None

    def say(self, text: str) -> None:
        self._run(self._publish(topics.TEXT_FROM_SPEECH, String(text)))

    def set_emotion(self, name: str) -> tuple[str, str | None]:
        self._run(self._publish(topics.SET_EMOTIONAL_STATE, String(name)))
        return name, None  # the emotion system resolves aliases; this tool has no configuration

    def set_values(self, pleasure: float, arousal: float, dominance: float) -> None:
        self._run(self._publish(topics.SET_EMOTIONAL_VALUES, EmotionalFeedback(pleasure, arousal, dominance)))

    def switch(self, on: bool) -> None:
        self._run(self._publish(topics.EMOTIONAL_CONTROLLER, String("on" if on else "off")))

    def status(self) -> dict[str, Any]:
        return self._run(self._status())

    async def _status(self) -> dict[str, Any]:
        status: dict[str, Any] = {"state": None, "previous_state": None, "event": None}
        changed = asyncio.Event()

        def on_change(message: SystemState, info: MessageInfo) -> None:
            _apply_change(status, message)
            changed.set()

        subscription = self._node.subscribe(topics.STATE_CHANGE, SystemState, on_change)
        try:
            proxy = self._node.service_proxy(topics.GET_EMOTIONAL_STATE, EmotionalStateService)
            await proxy.wait_for_service(CONNECT_TIMEOUT)  # ROS 2: discovery takes a moment
            try:
                answer = await proxy.call(timeout=CONNECT_TIMEOUT)
            except (ServiceUnavailableError, ServiceTimeoutError):
                raise CyborgError(
                    f"no emotion system answers on {topics.GET_EMOTIONAL_STATE}; fix: start the node "
                    f"cyborg_controller (`cyborg launch`), or check {self.middleware.graph_setting}"
                ) from None
            status.update(
                emotion=answer.emotional_state,
                pleasure=answer.current_pleasure,
                arousal=answer.current_arousal,
                dominance=answer.current_dominance,
            )
            await self._see_parameters()
            enabled = self._node.get_param(topics.EMOTION_ENABLED_PARAM, None)
            status["emotion_enabled"] = enabled if isinstance(enabled, bool) else None
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(changed.wait(), CONNECT_TIMEOUT)  # latched: arrives at once
        finally:
            subscription.unsubscribe()
        return status

    def follow(self, status: dict[str, Any], show: Callable[[dict[str, Any]], None]) -> None:
        """Call ``show`` with the updated status on every state change and emotion update, until SIGINT."""
        self._run(self._follow(status, show))

    async def _follow(self, status: dict[str, Any], show: Callable[[dict[str, Any]], None]) -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        last: dict[str, Any] = dict(status)

        def update(apply: Callable[[], None]) -> None:
            apply()
            if status != last:  # the latched messages repeat what the status already shows
                last.clear()
                last.update(status)
                show(status)

        def on_change(message: SystemState, info: MessageInfo) -> None:
            update(lambda: _apply_change(status, message))

        def on_emotion(message: EmotionalState, info: MessageInfo) -> None:
            update(
                lambda: status.update(
                    emotion=message.to_emotional_state,
                    pleasure=message.current_pleasure,
                    arousal=message.current_arousal,
                    dominance=message.current_dominance,
                )
            )

        self._node.subscribe(topics.STATE_CHANGE, SystemState, on_change, queue_size=1000)
        self._node.subscribe(topics.EMOTIONAL_STATE, EmotionalState, on_emotion, queue_size=1000)
        await stop.wait()


def _apply_change(status: dict[str, Any], message: SystemState) -> None:
    status.update(
        state=message.to_system_state, previous_state=message.from_system_state, event=message.event
    )
