"""Actions of the ROS 1 transport: servers and clients on actionlib.

Part of :mod:`cyborg.transport.ros`. The server side wraps actionlib's goal handles; the client
side keeps each goal in the shared :class:`~cyborg.transport._goals.ClientGoal`, fed from
actionlib's transition and feedback callbacks (rospy threads) on the clock's event loop. A
server that stops reporting its status is gone: its goals end LOST (actionlib alone would wait
forever).

Our servers report their status once a second (STATUS_FREQUENCY) instead of actionlib's 5 Hz: ten
idle modules sent the controller 50 status messages a second, each woke a thread at both ends.
The status is latched and also sent at every change of a goal, so a client still learns at once
of a new server and of every transition; only a server that hangs (alive, silent) is noticed later
(SERVER_SILENCE_LIMIT). actionlib's own parameter ``actionlib_status_frequency`` (or the
deprecated ``<action>/status_frequency``), when set on the master, wins as it does for any
actionlib server.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import threading
import time
from collections.abc import Awaitable, Callable
from typing import Any

import actionlib  # type: ignore[import-not-found]
import rospy  # type: ignore[import-not-found]
from actionlib_msgs.msg import GoalStatusArray  # type: ignore[import-not-found]

from cyborg.transport._goals import ClientGoal
from cyborg.transport._host import LOCKSTEP_FIND_LIMIT, Host, poll_real
from cyborg.transport.base import (
    ActionClient,
    ActionServer,
    ClientGoalHandle,
    F,
    G,
    GoalStatus,
    R,
    ServerGoalHandle,
)
from cyborg.transport.ledger import Channel
from cyborg.transport.messages import ActionType, Message
from cyborg.transport.ros import reads
from cyborg.transport.ros.convert import from_ros, ros_class, sender, to_ros
from cyborg.transport.ros.master import UNREACHABLE, WATCH

__all__ = [
    "ORDER_EXECUTE",
    "ORDER_FIELD",
    "SERVER_SILENCE_LIMIT",
    "STATUS_FREQUENCY",
    "WATCHDOG_PERIOD",
    "RosActionClient",
    "RosActionServer",
    "goal_order",
]

log = logging.getLogger(__name__)

STATUS_FREQUENCY = 1.0
"""Status messages a second from our action servers while nothing changes (actionlib's default: 5)."""
ACTIONLIB_STATUS_FREQUENCY = 5.0  # actionlib's default, used when no parameter sets it
SERVER_SILENCE_LIMIT = 3.0
"""Seconds without a status message before an action server counts as gone (three of our status
periods; a server that dies is seen sooner: its connections close)."""
LOCKSTEP_SILENCE_LIMIT = 5.0
"""Real seconds of silence in lockstep time: the server's status timer thread runs only when the
machine gives it the CPU, and the granted time may race ahead meanwhile (3 CPU hogs beside a
lockstep run starved it for over a second and a live server's goal ended LOST)."""
WATCHDOG_PERIOD = 0.5
"""Seconds between two looks of an action client at its server while one of its goals runs: a
server that died (its connections closed) ends the goal LOST within this. (0.2 s woke the
controller and the navigation module five times a second each while the robot wandered.)"""
LOCKSTEP_WATCHDOG_PERIOD = 2.0  # lockstep time: a look every 0.2 s would be most of a run's time steps

# The published cyborg_controller package (scripts/install-ros --flavour public) has a fourth goal
# field, ``string order``, which its controller always sets to EXECUTE: a goal sent with those
# definitions installed carries it, so a module built against that package sees what it expects.
ORDER_FIELD = "order"
ORDER_EXECUTE = "EXECUTE"


def goal_order(goal_cls: Any, goal_type: type[Message]) -> str | None:
    """EXECUTE when the installed goal class has a string ``order`` field that ``goal_type`` lacks."""
    slots = dict(zip(getattr(goal_cls, "__slots__", ()), getattr(goal_cls, "_slot_types", ()), strict=False))
    if slots.get(ORDER_FIELD) != "string" or ORDER_FIELD in {f.name for f in dataclasses.fields(goal_type)}:
        return None
    return ORDER_EXECUTE


def _action_classes(action_type: ActionType[Any, Any, Any]) -> Any:
    return ros_class(action_type.ros_type)


# --- the server side ----------------------------------------------------------------------


class _RosServerGoalHandle(ServerGoalHandle[G, R, F]):
    def __init__(self, server: RosActionServer[G, R, F], ros_handle: Any) -> None:
        self._server = server
        self._handle = ros_handle
        goal_id = ros_handle.get_goal_id()
        self.goal_id = str(goal_id.id)
        self.goal = from_ros(ros_handle.get_goal(), server.action_type.goal)
        self.sender = sender(ros_handle.get_goal()) or str(goal_id.id).split("-", 1)[0].lstrip("/")

    @property
    def status(self) -> GoalStatus:
        return GoalStatus(int(self._handle.get_goal_status().status))

    def _result(self, result: R | None) -> Any:
        return to_ros(
            result if result is not None else self._server.action_type.result(), self._server.result_cls
        )

    def accept(self) -> None:
        self._guard(self._handle.set_accepted, "")

    def reject(self, result: R | None = None, text: str = "") -> None:
        self._guard(self._handle.set_rejected, self._result(result), text)

    def publish_feedback(self, feedback: F) -> None:
        if not self.status.is_terminal:
            self._handle.publish_feedback(to_ros(feedback, self._server.feedback_cls))

    def succeed(self, result: R | None = None, text: str = "") -> None:
        self._guard(self._handle.set_succeeded, self._result(result), text)

    def abort(self, result: R | None = None, text: str = "") -> None:
        self._guard(self._handle.set_aborted, self._result(result), text)

    def canceled(self, result: R | None = None, text: str = "") -> None:
        self._guard(self._handle.set_canceled, self._result(result), text)

    def _guard(self, method: Callable[..., None], *args: Any) -> None:
        before = self.status
        try:
            method(*args)
        except Exception:
            log.warning(
                "action %s: %s failed in status %s", self._server.name, method.__name__, self.status.name
            )
        after = self.status
        ledger = self._server.ledger
        if ledger is not None and after is not before:
            if before in (GoalStatus.PENDING, GoalStatus.RECALLING):
                ledger.sent(f"{self._server.name}#accept")  # the goal's first answer
            if after.is_terminal:
                ledger.sent(f"{self._server.name}#result")
        if after.is_terminal:
            self._server.forget(self.goal_id)


class RosActionServer(ActionServer[G, R, F]):
    def __init__(
        self,
        transport: Host,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
    ) -> None:
        self.name = name
        self.action_type = action_type
        self._transport = transport
        self._on_goal = on_goal
        self._on_cancel = on_cancel
        self.result_cls = ros_class(action_type.result.ros_type)
        self.feedback_cls = ros_class(action_type.feedback.ros_type)
        self._handles: dict[str, _RosServerGoalHandle[G, R, F]] = {}
        self._lock = threading.Lock()
        self.ledger = transport.clock.ledger
        if self.ledger is not None:
            self.ledger.listen(f"{name}#goal", Channel.UNICAST)
            self.ledger.listen(f"{name}#cancel", Channel.UNICAST)
        self._server = _CountingActionServer(
            name, _action_classes(action_type), self._goal_cb, self._cancel_cb, auto_start=False
        )
        self._server.arrived = self._arrived
        reads.mark(self._server, transport.clock)  # its goal and cancel subscribers read on the loop
        self._server.start()

    def _arrived(self, leg: str) -> None:  # rospy thread: actionlib took a goal or cancel message
        """Count a goal or cancel message that reached none of our callbacks (a duplicate goal, a
        cancel of a finished one): lockstep time must see it arrive."""
        if self.ledger is not None:
            self._transport.arrive(f"{self.name}#{leg}", "", _nothing, counted=(f"{self.name}#{leg}",))

    def _wrap(self, ros_handle: Any) -> _RosServerGoalHandle[G, R, F]:
        key = str(ros_handle.get_goal_id().id)
        with self._lock:
            handle = self._handles.get(key)
            if handle is None:
                handle = self._handles[key] = _RosServerGoalHandle(self, ros_handle)
            return handle

    def forget(self, goal_id: str) -> None:
        """Drop a finished goal's wrapper (a late cancel gets a fresh one, which sees it finished)."""
        with self._lock:
            self._handles.pop(goal_id, None)

    def _goal_cb(self, ros_handle: Any) -> None:  # rospy thread
        handle = self._wrap(ros_handle)
        leg = f"{self.name}#goal"
        self._server.delivered = True
        self._transport.arrive(leg, handle.sender, self._on_goal, handle, counted=(leg,))

    def _cancel_cb(self, ros_handle: Any) -> None:  # rospy thread
        leg = f"{self.name}#cancel"
        counted = () if self._server.delivered else (leg,)  # one count for one cancel message
        self._server.delivered = True
        self._transport.arrive(leg, "", self._on_cancel, self._wrap(ros_handle), counted=counted)

    def shutdown(self) -> None:
        """Leave the graph quietly: first stop hearing goals and cancels, then stop publishing.

        A node going down with its client (Ctrl-C to a launch) still gets a cancel or two: rospy
        may be running one on its threads while we unregister. actionlib would answer it with a
        status on a closed topic ("publish() to a closed topic", a traceback in the terminal),
        so from here on its server publishes nothing.
        """
        for attribute in ("goal_sub", "cancel_sub"):
            subscriber = getattr(self._server, attribute, None)
            if subscriber is not None:
                subscriber.unregister()
        timer = getattr(self._server, "status_timer", None)
        if timer is not None:
            timer.shutdown()
        for method in ("publish_status", "publish_result", "publish_feedback"):
            setattr(self._server, method, _publish_nothing)
        for attribute in ("status_pub", "result_pub", "feedback_pub"):
            publisher = getattr(self._server, attribute, None)
            if publisher is not None:
                publisher.unregister()


class _CountingActionServer(actionlib.ActionServer):  # type: ignore[misc]
    """actionlib's server, saying when it has handled each goal and cancel message (lockstep time
    counts them as received after their callbacks are on the loop)."""

    arrived: Callable[[str], None] | None = None
    delivered = False  # a goal or cancel callback of ours ran for the message being taken
    ns: str  # (actionlib's, set in its __init__ and initialize)
    status_frequency: float
    status_timer: Any

    def initialize(self) -> None:
        """actionlib's set-up, with our status frequency unless a parameter on the master sets one."""
        super().initialize()
        if self.status_frequency != ACTIONLIB_STATUS_FREQUENCY or _frequency_parameter_set(self.ns):
            return
        if self.status_timer is not None:
            self.status_timer.shutdown()
        self.status_frequency = STATUS_FREQUENCY
        self.status_timer = rospy.Timer(rospy.Duration(1.0 / STATUS_FREQUENCY), self.publish_status_async)

    def internal_goal_callback(self, goal: Any) -> None:
        self.delivered = False
        try:
            super().internal_goal_callback(goal)
        finally:
            if self.arrived is not None and not self.delivered:
                self.arrived("goal")

    def publish_status(self) -> None:
        """actionlib's, without its debug line for each finished goal it drops from the list: that
        line formats the goal's id as YAML whether debug logging is on or not, about 0.3 ms of an
        accept or cancel that drops one (at once when goals follow each other quickly)."""
        with self.lock:
            now = rospy.Time.now()
            kept = [
                tracker
                for tracker in self.status_list
                if tracker.handle_destruction_time == _NEVER
                or tracker.handle_destruction_time + self.status_list_timeout >= now
            ]
            self.status_list[:] = kept
            status_array = GoalStatusArray(status_list=[tracker.status for tracker in kept])
            status_array.header.stamp = now
            if not rospy.is_shutdown():
                self.status_pub.publish(status_array)

    def internal_cancel_callback(self, goal_id: Any) -> None:
        self.delivered = False
        try:
            super().internal_cancel_callback(goal_id)
        finally:
            if self.arrived is not None and not self.delivered:
                self.arrived("cancel")


def _frequency_parameter_set(namespace: str) -> bool:
    """Whether the master holds a status frequency for the server at ``namespace`` (actionlib's
    parameters; a master that does not answer holds none we could read)."""
    try:
        return bool(
            rospy.has_param(rospy.remap_name(namespace) + "/status_frequency")
            or rospy.search_param("actionlib_status_frequency") is not None
        )
    except UNREACHABLE:
        return False


_NEVER = rospy.Time()  # a goal's destruction time while it runs
_UNANSWERED = frozenset({GoalStatus.PENDING, GoalStatus.RECALLING})  # the server has not answered yet


def _nothing() -> None:
    """What a counted arrival without a callback runs."""


def _publish_nothing(*args: object) -> None:
    """What a shut-down actionlib server publishes (its publishers are closed)."""


# --- the client side ----------------------------------------------------------------------


class _WatchedActionClient(actionlib.ActionClient):  # type: ignore[misc]
    """actionlib's client, remembering when the server last reported its status."""

    last_status_time = 0.0
    last_status_virtual = 0.0
    lockstep_clock: Any = None  # with lockstep time: the clock, whose time moves only when granted

    def _status_cb(self, msg: Any) -> None:
        self.last_status_time = time.monotonic()
        if self.lockstep_clock is not None:
            self.last_status_virtual = self.lockstep_clock.monotonic()
        super()._status_cb(msg)

    def silent(self) -> bool:
        """No status for SERVER_SILENCE_LIMIT real seconds (with lockstep time: and virtual ones,
        as the server's status timer runs on the granted time, which may stand still a while)."""
        clock = self.lockstep_clock
        limit = SERVER_SILENCE_LIMIT if clock is None else LOCKSTEP_SILENCE_LIMIT
        if time.monotonic() - self.last_status_time <= limit:
            return False
        reads.read_waiting(self.status_sub)  # the loop was busy: a status may wait unread
        if time.monotonic() - self.last_status_time <= limit:
            return False
        return clock is None or clock.monotonic() - self.last_status_virtual > SERVER_SILENCE_LIMIT


class _RosClientGoalHandle(ClientGoal[G, R, F]):
    """The shared client goal; a cancel goes through actionlib's goal handle once it was sent."""

    def __init__(
        self,
        client: RosActionClient[G, R, F],
        goal: G,
        on_feedback: Callable[[F], Awaitable[None] | None] | None,
        on_status: Callable[[GoalStatus], Awaitable[None] | None] | None,
    ) -> None:
        transport = client.transport
        super().__init__(
            goal,
            clock=transport.clock,
            run=transport.run_callback,
            on_feedback=on_feedback,
            on_status=on_status,
        )
        self._client = client
        self._ros: Any = None

    def _request_cancel(self) -> None:
        if self._ros is not None:
            ledger = self._client.transport.clock.ledger
            if ledger is not None:
                ledger.sent(f"{self._client.name}#cancel")
            self._ros.cancel()

    def _finished(self) -> None:
        self._client.forget(self)


class RosActionClient(ActionClient[G, R, F]):
    def __init__(self, transport: Host, name: str, action_type: ActionType[G, R, F]) -> None:
        self.name = name
        self.transport = transport
        self.action_type = action_type
        self._goal_cls = ros_class(action_type.goal.ros_type)
        self._order = goal_order(self._goal_cls, action_type.goal)  # the public package's 'order'
        self._classes = _action_classes(action_type)
        self._client: Any = None
        self._active: set[_RosClientGoalHandle[G, R, F]] = set()
        self._watchdog: asyncio.TimerHandle | None = None
        self._ledger = transport.clock.ledger
        if self._ledger is not None:
            self._ledger.listen(f"{name}#accept", Channel.UNICAST)
            self._ledger.listen(f"{name}#result", Channel.UNICAST)
        self._make_client()

    def _make_client(self) -> bool:
        """Make actionlib's client, unless made already. actionlib asks the master for parameters
        while it makes one: while the master is away it cannot, and what it made so far is undone;
        the client is made at a later look for the server (``server_available``)."""
        if self._client is not None:
            return True
        client = _WatchedActionClient.__new__(_WatchedActionClient)
        reads.mark(client, self.transport.clock)  # its status, result and feedback read on the loop
        try:
            actionlib.ActionClient.__init__(client, self.name, self._classes)
        except UNREACHABLE as exc:
            for part in ("pub_goal", "pub_cancel", "status_sub", "result_sub", "feedback_sub"):
                if (made := getattr(client, part, None)) is not None:
                    made.unregister()
            WATCH.missed(f"make the action client {self.name}", exc)
            return False
        if self.transport.clock.is_lockstep:
            client.lockstep_clock = self.transport.clock
        self._client = client
        return True

    def server_available(self) -> bool:
        """The server is reporting its status and connected both ways, as actionlib's own
        ``wait_for_server`` checks: goal and cancel reach it, its results and feedback reach us.
        (A result published before our result subscriber is connected is lost, and the goal
        would wait for it forever.)"""
        if not self._make_client():
            return False
        client = self._client
        if client.last_status_msg is None:
            reads.read_waiting(client.status_sub)  # (the loop may not have read it yet)
        last = client.last_status_msg
        if last is None or client.silent():
            return False
        server = last._connection_header["callerid"]
        if not (
            client.pub_goal.impl.has_connection(server) and client.pub_cancel.impl.has_connection(server)
        ):
            return False
        return all(
            any(connection.callerid_pub == server for connection in subscriber.impl.connections)
            for subscriber in (client.result_sub, client.feedback_sub)
        )

    async def wait_for_server(self, timeout: float) -> bool:
        """Poll :meth:`server_available` until ``timeout`` *real* seconds pass.

        rospy and actionlib find a server on their own threads, in real time, whatever speed the
        clock runs at: a deadline on a virtual clock at speed 25 would give them 1/25 of it, and a
        module's server found a moment late would end its state as aborted.
        """
        clock = self.transport.clock
        limit = max(timeout, LOCKSTEP_FIND_LIMIT) if clock.is_lockstep else timeout
        return await poll_real(self.server_available, clock, limit)

    def send_goal(
        self,
        goal: G,
        *,
        on_feedback: Callable[[F], Awaitable[None] | None] | None = None,
        on_status: Callable[[GoalStatus], Awaitable[None] | None] | None = None,
    ) -> ClientGoalHandle[G, R, F]:
        handle = _RosClientGoalHandle(self, goal, on_feedback, on_status)
        transport = self.transport
        answered = False
        forwarded: GoalStatus | None = None  # the status last handed to the loop

        def transition(ros_handle: Any) -> None:  # rospy thread (under the goal's lock)
            nonlocal answered, forwarded
            status = GoalStatus(int(ros_handle.get_goal_status()))
            result = None
            text = ""
            done = ros_handle.get_comm_state() == actionlib.CommState.DONE
            if done:
                raw = ros_handle.get_result()
                result = (
                    from_ros(raw, self.action_type.result) if raw is not None else self.action_type.result()
                )
                text = str(ros_handle.get_goal_status_text())
            elif status.is_terminal:
                return  # wait for DONE to carry the result
            # Lockstep time counts the goal's first answer (accepted, or ended at once) and its result.
            # A goal cancelled before its acceptance reached us shows no ACTIVE (actionlib skips it
            # while it waits for the cancel's answer): PREEMPTING says the server accepted it.
            counted = []
            if not answered and (done or status not in _UNANSWERED):
                answered = True
                counted.append(f"{self.name}#accept")
            if done:
                counted.append(f"{self.name}#result")
            elif not counted and status is forwarded:
                return  # nothing new (our own cancel() reports the status it had): no loop turn for it
            forwarded = status
            leg = "result" if done else "accept" if status is GoalStatus.ACTIVE else "status"
            transport.arrive(
                f"{self.name}#{leg}", "", handle.update_status, status, result, text, counted=counted
            )

        def feedback(ros_handle: Any, ros_feedback: Any) -> None:  # rospy thread
            fb = from_ros(ros_feedback, self.action_type.feedback)
            transport.arrive(f"{self.name}#feedback", "", handle.deliver_feedback, fb)

        if not self.server_available():
            transport.clock.loop.call_soon(
                handle.update_status, GoalStatus.LOST, None, f"no action server at {self.name}"
            )
            return handle
        ros_goal = to_ros(goal, self._goal_cls)
        if self._order is not None:
            setattr(ros_goal, ORDER_FIELD, self._order)
        if self._ledger is not None:
            self._ledger.sent(f"{self.name}#goal")
        handle._ros = self._client.send_goal(ros_goal, transition, feedback)
        self._active.add(handle)
        self._arm_watchdog()
        return handle

    def forget(self, handle: _RosClientGoalHandle[G, R, F]) -> None:
        self._active.discard(handle)

    def _arm_watchdog(self) -> None:
        if self._watchdog is None:
            clock = self.transport.clock
            period = LOCKSTEP_WATCHDOG_PERIOD if clock.is_lockstep else WATCHDOG_PERIOD
            self._watchdog = clock.loop.call_later(period, self._check_server)

    def _check_server(self) -> None:
        """Goals of a vanished server end LOST (actionlib alone would wait forever)."""
        self._watchdog = None
        if not self._active:
            return
        if not self.server_available():
            for handle in list(self._active):
                handle.update_status(GoalStatus.LOST, None, "action server gone")
            return
        self._arm_watchdog()

    def close(self) -> None:
        if self._watchdog is not None:
            self._watchdog.cancel()
        if self._client is not None:
            self._client.stop()
