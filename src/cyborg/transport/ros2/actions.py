"""Actions of the ROS 2 transport: servers and clients on ``rclpy.action``, with actionlib's semantics.

Part of :mod:`cyborg.transport.ros2`. ROS 2 actions differ from actionlib's, and this module
keeps the interface's (actionlib's) meaning on top of them:

* A goal is PENDING until the server's module accepts or rejects it: rclpy's goal callback
  waits (on an executor thread) for that decision. ACCEPTED and EXECUTING are both ACTIVE.
* A cancel of an active goal asks the module (``on_cancel``), which acknowledges it with
  ``canceled()``: ROS 2's CANCELED, which the client reports as PREEMPTED. A cancel of a goal
  the module has not accepted yet (ROS 2 has no such cancel: the goal is not known to rcl) is
  recognised by our server by its goal id and ends it RECALLED (the goal request is rejected,
  and the client, having asked to cancel it, reports RECALLED). Against a server of another
  kind (plain rclpy), the client sends the cancel once the goal is accepted.
* ROS 2 has no status text: our servers publish each goal's text (``reject(text=...)``,
  ``abort(text=...)``) on ``<action>/_cyborg_text`` before they end it, and our clients wait
  up to TEXT_WAIT seconds for it when the server has such a publisher.
* A server that stops being offered (its node or process gone) ends its goals LOST.
"""

from __future__ import annotations

import logging
import threading
import uuid
from collections.abc import Awaitable, Callable
from typing import Any

from action_msgs.msg import GoalStatus as RosGoalStatus
from rclpy.action import ActionClient as RclActionClient
from rclpy.action import ActionServer as RclActionServer
from rclpy.action import CancelResponse, GoalResponse
from rclpy.action.client import ClientGoalHandle as RclClientGoalHandle
from rclpy.action.server import RCLError
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node as RclNode
from std_msgs.msg import String as RosString
from unique_identifier_msgs.msg import UUID

from cyborg.transport._goals import ClientGoal
from cyborg.transport._host import poll_until
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
from cyborg.transport.messages import ActionType
from cyborg.transport.ros2.convert import from_ros2, ros2_class, to_ros2
from cyborg.transport.ros2.host import Host
from cyborg.transport.ros2.services import only_client
from cyborg.transport.ros2.topics import volatile_qos

__all__ = ["TEXT_TOPIC", "TEXT_WAIT", "WATCHDOG_PERIOD", "Ros2ActionClient", "Ros2ActionServer"]

log = logging.getLogger(__name__)

TEXT_TOPIC = "_cyborg_text"  # below the action's name
TEXT_WAIT = 0.3  # seconds a finished goal waits for its text from one of our servers
WATCHDOG_PERIOD = 0.2
LOCKSTEP_WATCHDOG_PERIOD = 2.0  # lockstep time: a look every 0.2 s would be most of a run's time steps
DECISION_LIMIT = 3600.0  # seconds a goal may stay pending before the server gives up on it
CANCEL_SETTLE = 1.0  # seconds the execute thread waits for rcl to mark a goal canceling
# Seconds a finished goal stays in our server's status (and its result for a late request), as
# actionlib's status_list_timeout (rclpy's default: 10). Every status message lists every goal
# kept, and every client of the action turns it into Python objects, in the executor (1.6 ms a
# message with 150 goals kept, at the handover benchmark's pace); our clients ask for the result
# as soon as a goal is accepted, so none comes late.
RESULT_KEPT = 5

RESULT_SEND_TRIES = 40  # a result the middleware cannot send is tried again this often,
RESULT_SEND_PAUSE = 0.1  # this many seconds apart (Fast DDS waits 100 ms itself each try)

_ACCEPT, _REJECT, _RECALL = "accept", "reject", "recall"


RESULT_HALVES_KEPT = 1000
_ENDED = "ended"
_ASKED = "asked"


def _nothing() -> None:
    """What a counted arrival without a callback runs."""


def _text_message(goal_id: bytes, text: str) -> RosString:
    return RosString(data=f"{goal_id.hex()}\t{text}")


# --- the server side ----------------------------------------------------------------------


class _Ros2ServerGoalHandle(ServerGoalHandle[G, R, F]):
    """One goal at our server: the module's decisions, handed to the executor threads."""

    def __init__(self, server: Ros2ActionServer[G, R, F], goal_id: bytes, goal: G, sender: str) -> None:
        self._server = server
        self.goal_id = goal_id.hex()
        self._id = goal_id
        self.goal = goal
        self.sender = sender
        self._status = GoalStatus.PENDING
        self._lock = threading.Lock()
        self.decided = threading.Event()  # accept, reject or recall chosen
        self.decision = ""
        self.finished = threading.Event()  # a terminal outcome chosen
        self.cancel_marked = threading.Event()  # rcl has marked the accepted goal canceling
        self.outcome: tuple[GoalStatus, Any] | None = None
        self.ros_handle: Any = None
        self._feedback: list[Any] = []

    @property
    def status(self) -> GoalStatus:
        return self._status

    def accept(self) -> None:
        with self._lock:
            if self._status is not GoalStatus.PENDING:
                return
            self._status = GoalStatus.ACTIVE
            self.decision = _ACCEPT
        self._server.count_sent("accept")
        self.decided.set()

    def reject(self, result: R | None = None, text: str = "") -> None:
        with self._lock:
            if self._status not in (GoalStatus.PENDING, GoalStatus.RECALLING):
                return
            self._status = GoalStatus.REJECTED
            self.decision = _REJECT
        self._server.publish_text(self._id, text)
        self._server.count_sent("accept")
        self.decided.set()

    def publish_feedback(self, feedback: F) -> None:
        ros_feedback = to_ros2(feedback, self._server.classes.Feedback)
        with self._lock:
            if self._status.is_terminal:
                return
            if self.ros_handle is None:
                self._feedback.append(ros_feedback)
                return
            handle = self.ros_handle
        handle.publish_feedback(ros_feedback)

    def attach(self, ros_handle: Any) -> None:  # executor thread, once accepted
        with self._lock:
            self.ros_handle = ros_handle
            pending, self._feedback = self._feedback, []
        for ros_feedback in pending:
            ros_handle.publish_feedback(ros_feedback)

    def succeed(self, result: R | None = None, text: str = "") -> None:
        self._finish(GoalStatus.SUCCEEDED, result, text)

    def abort(self, result: R | None = None, text: str = "") -> None:
        self._finish(GoalStatus.ABORTED, result, text)

    def canceled(self, result: R | None = None, text: str = "") -> None:
        with self._lock:
            recalling = self._status in (GoalStatus.PENDING, GoalStatus.RECALLING)
            if recalling:
                self._status = GoalStatus.RECALLED
                self.decision = _RECALL
        if recalling:
            self._server.publish_text(self._id, text)
            self._server.count_sent("accept")
            self.decided.set()
            return
        self._finish(GoalStatus.PREEMPTED, result, text)

    def _finish(self, status: GoalStatus, result: R | None, text: str) -> None:
        with self._lock:
            if self._status not in (GoalStatus.ACTIVE, GoalStatus.PREEMPTING):
                log.warning(
                    "action %s: cannot end goal %s %s in status %s",
                    self._server.name,
                    self.goal_id,
                    status.name,
                    self._status.name,
                )
                return
            self._status = status
            self.outcome = (status, result if result is not None else self._server.action_type.result())
        self._server.publish_text(self._id, text)
        self._server.result_ready(self._id)
        self.finished.set()

    def cancel_requested_now(self) -> bool:  # executor thread: a cancel came; True if it is new
        with self._lock:
            if self._status is GoalStatus.ACTIVE:
                self._status = GoalStatus.PREEMPTING
                return True
            if self._status is GoalStatus.PENDING:
                self._status = GoalStatus.RECALLING
                return True
            return False

    def lost(self) -> None:  # the server shuts down: nothing more is decided
        with self._lock:
            if not self._status.is_terminal:
                self._status = GoalStatus.LOST
        self.decided.set()
        self.finished.set()


class _RclServer(RclActionServer):  # type: ignore[misc]
    """rclpy's action server, telling our goal callback which goal it decides on, letting a
    cancel reach goals that wait for that decision (rcl knows only accepted goals), and sending a
    result again when the middleware could not send it (see :meth:`_send_result_response`)."""

    owner: Ros2ActionServer[Any, Any, Any] | None = None
    _deciding = threading.local()

    async def _execute_goal_request(self, request_header_and_message: Any) -> None:
        _RclServer._deciding.goal_id = bytes(request_header_and_message[1].goal_id.uuid)
        await super()._execute_goal_request(request_header_and_message)

    async def _execute_get_result_request(self, request_header_and_message: Any) -> None:
        if self.owner is not None:
            self.owner.result_requested(bytes(request_header_and_message[1].goal_id.uuid))
        await super()._execute_get_result_request(request_header_and_message)

    def _send_result_response(self, request_header: Any, future: Any) -> None:
        """Send a finished goal's result to a client that asked for it; try again a little later
        when the middleware cannot. Fast DDS refuses a response ("client will not receive
        response") when it has not matched the client's reader within 100 ms, which a loaded
        machine can miss; rclpy then drops the result, and the client waited for it forever."""
        result = future.result() if future.exception() is None else None
        if result:
            self._send_result(request_header, result, RESULT_SEND_TRIES)

    def _send_result(self, request_header: Any, result: Any, tries: int) -> None:
        try:
            self._send_result_now(request_header, result)
        except RCLError:
            owner = self.owner
            if owner is None or owner.is_closed:
                return
            if tries <= 1:
                log.warning("action %s: could not send a result to its client; it is lost", owner.name)
                return
            retry = threading.Timer(RESULT_SEND_PAUSE, self._send_result, (request_header, result, tries - 1))
            retry.daemon = True
            retry.start()
        except Exception:  # destroyed meanwhile (the node left): nobody waits for it here
            log.debug("action result not sent: the server is gone", exc_info=True)

    def _send_result_now(self, request_header: Any, result: Any) -> None:
        with self._lock:
            self._handle.send_result_response(request_header, result)

    async def _execute_cancel_request(self, request_header_and_message: Any) -> None:
        if self.owner is not None:
            self.owner.cancel_pending(request_header_and_message[1])
        await super()._execute_cancel_request(request_header_and_message)
        if self.owner is not None:
            self.owner.cancels_marked()


class Ros2ActionServer(ActionServer[G, R, F]):
    def __init__(
        self,
        transport: Host,
        node: RclNode,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
        callback_group: Any,
    ) -> None:
        self.name = name
        self.action_type = action_type
        self.classes = ros2_class(action_type.ros_type, "action")
        self._transport = transport
        self._node = node
        self._on_goal = on_goal
        self._on_cancel = on_cancel
        self._goals: dict[bytes, _Ros2ServerGoalHandle[G, R, F]] = {}
        self._lock = threading.Lock()
        # Lockstep: a goal's result goes out once the module has ended the goal AND its client
        # has asked for it (ROS 2 pulls results); the first of the two to come is noted here.
        self._result_halves: dict[bytes, str] = {}
        self._closed = False
        self._ledger = transport.clock.ledger
        if self._ledger is not None:
            self._ledger.listen(f"{name}#goal", Channel.UNICAST)
            self._ledger.listen(f"{name}#cancel", Channel.UNICAST)
            self._ledger.listen(f"{name}#get_result", Channel.UNICAST)
        # Our own side topic, one type, one QoS: no event handlers (each one more entity in the wait
        # set the executor builds for every message: cyborg.transport.ros2.topics).
        self._text = node.create_publisher(
            RosString,
            f"{name}/{TEXT_TOPIC}",
            volatile_qos(100),
            event_callbacks=PublisherEventCallbacks(use_default_callbacks=False),
        )
        self._server = _RclServer(
            node,
            self.classes,
            name,
            execute_callback=self._execute,
            goal_callback=self._goal,
            handle_accepted_callback=self._accepted,
            cancel_callback=self._cancel,
            callback_group=callback_group,
            result_timeout=RESULT_KEPT,
        )
        self._server.owner = self

    def publish_text(self, goal_id: bytes, text: str) -> None:
        if not self._closed:
            self._text.publish(_text_message(goal_id, text))
            self.count_sent("text")

    def count_sent(self, leg: str) -> None:
        """Lockstep time: count one message of ``leg`` (accept, result, text) sent."""
        if self._ledger is not None:
            self._ledger.sent(f"{self.name}#{leg}")

    @property
    def is_closed(self) -> bool:
        """The server was withdrawn."""
        return self._closed

    def result_ready(self, goal_id: bytes) -> None:
        """The module ended the goal (on the loop): in lockstep, the result is on its way if its
        client has asked for it already."""
        if self._ledger is not None and self._result_half(goal_id, _ENDED):
            self.count_sent("result")

    def result_requested(self, goal_id: bytes) -> None:  # executor thread
        """A client asked for a goal's result: in lockstep, count the request received, and the
        result sent if rclpy answers at once (the module has ended the goal, or it is unknown)."""
        if self._ledger is None:
            return
        if self._result_half(goal_id, _ASKED):
            self.count_sent("result")
        leg = f"{self.name}#get_result"
        self._transport.arrive(leg, "", _nothing, counted=(leg,))  # wakes the loop to report

    def _result_half(self, goal_id: bytes, half: str) -> bool:
        """Note ``half`` of a goal's result; True when the result goes out now."""
        with self._lock:
            other = self._result_halves.pop(goal_id, None)
            if other is not None and other != half:
                return True
            if half == _ASKED and goal_id not in self._goals:
                return True  # rclpy answers a goal it no longer runs (or never knew) at once
            self._result_halves[goal_id] = half
            if len(self._result_halves) > RESULT_HALVES_KEPT:  # ended goals nobody asked about
                del self._result_halves[next(iter(self._result_halves))]
            return False

    # executor threads
    def _goal(self, ros_goal: Any) -> GoalResponse:
        goal_id: bytes = getattr(_RclServer._deciding, "goal_id", uuid.uuid4().bytes)
        sender = only_client(self._node, f"{self.name}/_action/send_goal")
        handle = _Ros2ServerGoalHandle(self, goal_id, from_ros2(ros_goal, self.action_type.goal), sender)
        with self._lock:
            if self._closed:
                return GoalResponse.REJECT
            self._goals[goal_id] = handle
        leg = f"{self.name}#goal"
        self._transport.arrive(leg, sender, self._on_goal, handle, counted=(leg,))
        if not handle.decided.wait(DECISION_LIMIT):
            log.warning(
                "action %s: goal %s was neither accepted nor rejected; rejecting it",
                self.name,
                handle.goal_id,
            )
        if handle.decision == _ACCEPT:
            return GoalResponse.ACCEPT
        with self._lock:
            self._goals.pop(goal_id, None)
        return GoalResponse.REJECT

    def _accepted(self, ros_handle: Any) -> None:
        handle = self._goals.get(bytes(ros_handle.goal_id.uuid))
        if handle is not None:
            handle.attach(ros_handle)
        ros_handle.execute()

    def _execute(self, ros_handle: Any) -> Any:
        goal_id = bytes(ros_handle.goal_id.uuid)
        handle = self._goals.get(goal_id)
        if handle is None:
            ros_handle.abort()
            return self.classes.Result()
        try:
            handle.finished.wait()
            outcome = handle.outcome
            if outcome is None:  # lost: the server closes
                ros_handle.abort()
                return self.classes.Result()
            status, result = outcome
            ros_result = to_ros2(result, self.classes.Result)
            if status is GoalStatus.SUCCEEDED:
                ros_handle.succeed()
            elif status is GoalStatus.PREEMPTED:
                # The module may acknowledge the cancel before rcl, just after our cancel
                # callback, marks the goal canceling; only then may it end CANCELED.
                handle.cancel_marked.wait(CANCEL_SETTLE)
                if ros_handle.is_cancel_requested:
                    ros_handle.canceled()
                else:
                    ros_handle.abort()
            else:
                ros_handle.abort()
            return ros_result
        finally:
            with self._lock:
                self._goals.pop(goal_id, None)

    def _cancel(self, ros_handle: Any) -> CancelResponse:
        handle = self._goals.get(bytes(ros_handle.goal_id.uuid))
        if handle is not None and handle.cancel_requested_now():
            self._transport.arrive(f"{self.name}#cancel", "", self._on_cancel, handle)
        return CancelResponse.ACCEPT

    def cancels_marked(self) -> None:
        """A cancel request was answered: its goals that rcl now marks canceling may end CANCELED."""
        if self._ledger is not None:  # after the cancel's callbacks: one count for the request
            leg = f"{self.name}#cancel"
            self._transport.arrive(leg, "", _nothing, counted=(leg,))
        with self._lock:
            goals = list(self._goals.values())
        for handle in goals:
            if handle.ros_handle is not None and handle.ros_handle.is_cancel_requested:
                handle.cancel_marked.set()

    def cancel_pending(self, request: Any) -> None:
        """A cancel request naming a goal that waits for the module's decision recalls it."""
        goal_id = bytes(request.goal_info.goal_id.uuid)
        with self._lock:
            handle = self._goals.get(goal_id)
        if handle is not None and handle.status is GoalStatus.PENDING and handle.cancel_requested_now():
            self._transport.arrive(f"{self.name}#cancel", "", self._on_cancel, handle)

    def shutdown(self) -> None:
        with self._lock:
            self._closed = True
            goals = list(self._goals.values())
        for handle in goals:
            handle.lost()
        self._server.destroy()
        self._node.destroy_publisher(self._text)


# --- the client side ----------------------------------------------------------------------

_TERMINAL = {
    RosGoalStatus.STATUS_SUCCEEDED: GoalStatus.SUCCEEDED,
    RosGoalStatus.STATUS_CANCELED: GoalStatus.PREEMPTED,
    RosGoalStatus.STATUS_ABORTED: GoalStatus.ABORTED,
}


class _RclClient(RclActionClient):  # type: ignore[misc]
    """rclpy's action client, handing a goal's answer and result to our client in the executor turn
    that took them: rclpy runs a future's callbacks as tasks of a later turn, which added about
    1.5 ms to every handover of the ROS 2 handover benchmark."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        # rclpy hands the client to the executor before it makes the client's lock: a turn of the
        # executor in between raised "'_RclClient' object has no attribute '_lock'".
        self._lock = threading.Lock()
        self._callbacks: dict[Any, Callable[[Any], None]] = {}  # future -> its callback, until called
        super().__init__(*args, **kwargs)

    def when_done(self, future: Any, callback: Callable[[Any], None]) -> None:
        """Call ``callback(future)`` once, as soon as the future is done."""
        self._callbacks[future] = callback
        future.add_done_callback(self._call_once)  # also when it was done before this

    def _call_once(self, future: Any) -> None:
        callback = self._callbacks.pop(future, None)
        if callback is not None:
            callback(future)

    async def execute(self, taken_data: Any) -> None:
        futures = [
            pending.get(taken_data[key][0])
            for key, pending in (
                ("goal", self._pending_goal_requests),
                ("result", self._pending_result_requests),
            )
            if key in taken_data
        ]
        await super().execute(taken_data)
        for future in futures:
            if future is not None and future.done():
                self._call_once(future)


class _Ros2ClientGoalHandle(ClientGoal[G, R, F]):
    """The shared client goal; a cancel goes to the server once it has answered the goal."""

    def __init__(
        self,
        client: Ros2ActionClient[G, R, F],
        goal: G,
        goal_id: bytes,
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
        self.goal_id = goal_id
        self.ros_handle: Any = None
        self.cancel_asked = False
        self.recall = False  # the cancel was asked while the goal was pending
        self.waiting_text: tuple[GoalStatus, Any] | None = None
        self.text_timer: Any = None

    def _request_cancel(self) -> None:
        if self.cancel_asked:
            return
        self.cancel_asked = True
        if self.status is GoalStatus.PENDING:
            self.recall = True
        self._client.send_cancel(self)

    def _finished(self) -> None:
        self._client.forget(self)


class Ros2ActionClient(ActionClient[G, R, F]):
    def __init__(
        self, transport: Host, node: RclNode, name: str, action_type: ActionType[G, R, F], callback_group: Any
    ) -> None:
        self.name = name
        self.transport = transport
        self.action_type = action_type
        self._node = node
        self.classes = ros2_class(action_type.ros_type, "action")
        self._client = _RclClient(node, self.classes, name, callback_group=callback_group)
        self._active: dict[bytes, _Ros2ClientGoalHandle[G, R, F]] = {}
        self._texts: dict[bytes, str] = {}
        self._text_topic = f"{name}/{TEXT_TOPIC}"
        self._text_sub = node.create_subscription(
            RosString,
            self._text_topic,
            self._on_text,
            volatile_qos(100),
            callback_group=callback_group,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False),  # as the server's
        )
        self._watchdog: Any = None
        self._closed = False
        self._ledger = transport.clock.ledger
        if self._ledger is not None:
            for leg in ("accept", "result"):
                self._ledger.listen(f"{name}#{leg}", Channel.UNICAST)
            self._ledger.listen(f"{name}#text", Channel.BROADCAST)

    def _count_sent(self, leg: str) -> None:
        if self._ledger is not None:
            self._ledger.sent(f"{self.name}#{leg}")

    def server_available(self) -> bool:
        return not self._closed and bool(self._client.server_is_ready())

    async def wait_for_server(self, timeout: float) -> bool:
        """Poll :meth:`server_available` on the clock (:func:`~cyborg.transport._host.poll_until`)."""
        return await poll_until(self.server_available, self.transport.clock, timeout)

    def send_goal(
        self,
        goal: G,
        *,
        on_feedback: Callable[[F], Awaitable[None] | None] | None = None,
        on_status: Callable[[GoalStatus], Awaitable[None] | None] | None = None,
    ) -> ClientGoalHandle[G, R, F]:
        goal_id = uuid.uuid4().bytes
        handle = _Ros2ClientGoalHandle(self, goal, goal_id, on_feedback, on_status)
        loop = self.transport.clock.loop
        if not self.server_available():
            loop.call_soon(handle.update_status, GoalStatus.LOST, None, f"no action server at {self.name}")
            return handle
        self._active[goal_id] = handle

        arrive, name = self.transport.arrive, self.name

        def feedback(message: Any) -> None:  # executor thread
            fb = from_ros2(message.feedback, self.action_type.feedback)
            arrive(f"{name}#feedback", "", handle.deliver_feedback, fb)

        def answered(future: Any) -> None:  # executor thread
            response = future.result() if future.exception() is None else None
            arrive(f"{name}#accept", "", self._answered, handle, response, counted=(f"{name}#accept",))

        self._count_sent("goal")
        future = self._client.send_goal_async(
            to_ros2(goal, self.classes.Goal), feedback_callback=feedback, goal_uuid=UUID(uuid=list(goal_id))
        )
        self._client.when_done(future, answered)  # its client is in the executor's wait set: no wake
        self._arm_watchdog()
        return handle

    # on the loop
    def _answered(self, handle: _Ros2ClientGoalHandle[G, R, F], ros_handle: Any) -> None:
        if handle.status.is_terminal:
            return
        if ros_handle is None or not ros_handle.accepted:
            self._end(handle, GoalStatus.RECALLED if handle.recall else GoalStatus.REJECTED, None)
            return
        handle.ros_handle = ros_handle
        handle.update_status(GoalStatus.ACTIVE, None, "")
        arrive, name = self.transport.arrive, self.name

        def result(future: Any) -> None:  # executor thread
            response = future.result() if future.exception() is None else None
            arrive(f"{name}#result", "", self._resulted, handle, response, counted=(f"{name}#result",))

        self._count_sent("get_result")
        self._client.when_done(ros_handle.get_result_async(), result)
        if handle.cancel_asked:
            self.send_cancel(handle)

    def _resulted(self, handle: _Ros2ClientGoalHandle[G, R, F], response: Any) -> None:
        if response is None:
            self._end(handle, GoalStatus.LOST, None)
            return
        status = _TERMINAL.get(response.status, GoalStatus.LOST)
        if status is GoalStatus.PREEMPTED and handle.recall:
            status = GoalStatus.RECALLED
        self._end(handle, status, from_ros2(response.result, self.action_type.result))

    def send_cancel(self, handle: _Ros2ClientGoalHandle[G, R, F]) -> None:
        if self._closed:
            return  # its goals ended LOST when it closed
        self._count_sent("cancel")
        if handle.ros_handle is not None:
            handle.ros_handle.cancel_goal_async()
            if handle.status is GoalStatus.ACTIVE:
                handle.update_status(GoalStatus.PREEMPTING, None, "")
        else:
            # Not answered yet: our servers recall it now (they know its id); others get the
            # cancel once they accept it (_answered).
            pending = RclClientGoalHandle(self._client, UUID(uuid=list(handle.goal_id)), None)
            self._client._cancel_goal_async(pending)

    def _end(self, handle: _Ros2ClientGoalHandle[G, R, F], status: GoalStatus, result: R | None) -> None:
        """Finish ``handle`` with its text: now, or when its text arrives (up to TEXT_WAIT s)."""
        if status is not GoalStatus.LOST and handle.goal_id not in self._texts and self._text_expected():
            handle.waiting_text = (status, result)
            handle.text_timer = self.transport.clock.loop.call_later(TEXT_WAIT, self._text_done, handle)
            return
        handle.update_status(status, result, self._texts.pop(handle.goal_id, ""))

    def _text_expected(self) -> bool:
        return bool(self._node.count_publishers(self._text_topic))

    def _text_done(self, handle: _Ros2ClientGoalHandle[G, R, F]) -> None:
        if handle.waiting_text is None:
            return
        status, result = handle.waiting_text
        handle.waiting_text = None
        if handle.text_timer is not None:
            handle.text_timer.cancel()
        handle.update_status(status, result, self._texts.pop(handle.goal_id, ""))

    def _on_text(self, message: Any) -> None:  # executor thread
        goal_hex, _, text = message.data.partition("\t")
        try:
            goal_id = bytes.fromhex(goal_hex)
        except ValueError:
            return
        leg = f"{self.name}#text"
        self.transport.arrive(leg, "", self._got_text, goal_id, text, counted=(leg,))

    def _got_text(self, goal_id: bytes, text: str) -> None:
        handle = self._active.get(goal_id)
        if handle is None:
            return
        self._texts[goal_id] = text
        if handle.waiting_text is not None:
            self._text_done(handle)

    def forget(self, handle: _Ros2ClientGoalHandle[G, R, F]) -> None:
        self._active.pop(handle.goal_id, None)
        self._texts.pop(handle.goal_id, None)

    def _arm_watchdog(self) -> None:
        if self._watchdog is None:
            clock = self.transport.clock
            period = LOCKSTEP_WATCHDOG_PERIOD if clock.is_lockstep else WATCHDOG_PERIOD
            self._watchdog = clock.loop.call_later(period, self._check_server)

    def _check_server(self) -> None:
        """Goals of a vanished server end LOST (rclpy alone would wait for their result forever)."""
        self._watchdog = None
        if not self._active:
            return
        if not self.server_available():
            for handle in list(self._active.values()):
                handle.update_status(GoalStatus.LOST, None, "action server gone")
            return
        self._arm_watchdog()

    def close(self) -> None:
        """Withdraw the client; a goal still under way ends LOST (a cancel after this does nothing)."""
        if self._closed:
            return
        self._closed = True
        if self._watchdog is not None:
            self._watchdog.cancel()
            self._watchdog = None
        for handle in list(self._active.values()):
            handle.update_status(GoalStatus.LOST, None, "the action client was closed")
        self._node.destroy_subscription(self._text_sub)
        self._client.destroy()
