"""The ROS 1 transport's entry point: :class:`RosTransport`, its nodes and parameters.

Part of :mod:`cyborg.transport.ros`. Making a RosTransport installs the rospy patches
(:mod:`.patches`); its first node initialises this process's one rospy node and starts the
master watch (:mod:`.master`). A :class:`RosNode` hands out the topics (:mod:`.topics`),
services (:mod:`.services`) and actions (:mod:`.actions`) of the ROS 1 transport. Callbacks
arrive on rospy's threads, or on the loop that reads the subscriptions (:mod:`.reads`), and run
on the clock's event loop (:meth:`RosTransport.to_loop`).
"""

from __future__ import annotations

import copy
import logging
import threading
from collections.abc import Awaitable, Callable
from typing import Any

import rosgraph  # type: ignore[import-not-found]
import rospy  # type: ignore[import-not-found]

from cyborg.errors import TransportError
from cyborg.transport.base import (
    DEFAULT_QUEUE_SIZE,
    ActionClient,
    ActionServer,
    F,
    G,
    M,
    MessageInfo,
    Node,
    Publisher,
    R,
    Req,
    Resp,
    ServerGoalHandle,
    ServiceProxy,
    ServiceServer,
    Subscription,
    Transport,
    normalize_node_name,
)
from cyborg.transport.clock import Clock
from cyborg.transport.graph import GraphView
from cyborg.transport.lockstep import LockstepClock
from cyborg.transport.messages import ActionType, ServiceType
from cyborg.transport.ros import patches
from cyborg.transport.ros.actions import RosActionClient, RosActionServer
from cyborg.transport.ros.master import UNREACHABLE, WATCH, listed_subscribers
from cyborg.transport.ros.services import RosServiceProxy, RosServiceServer
from cyborg.transport.ros.topics import RosPublisher, RosSubscription, check_topic_type

__all__ = ["RosNode", "RosTransport"]

log = logging.getLogger(__name__)

_UNKNOWN = object()


class RosTransport(Transport):
    """Nodes of this process on a running ROS master (``ROS_MASTER_URI``)."""

    def __init__(self, clock: Clock, *, process_name: str | None = None) -> None:
        """``process_name``: this process's rospy node name (default: the first node's name)."""
        patches.install()
        super().__init__(clock)
        self.process_name = process_name
        self._watched_params: set[str] = set()
        self._param_values: dict[str, Any] = {}
        self._params_lock = threading.Lock()
        self._chained_notifier: Callable[[str, Any], None] | None = None

    def _ensure_init(self, first: str) -> None:
        if not rospy.core.is_initialized():
            lockstep = isinstance(self.clock, LockstepClock)
            # In lockstep rospy's time is set from the granted time in this process: a /clock
            # subscription in every node would wake every process at every step of the time.
            rospy.init_node(
                self.process_name or first, anonymous=False, disable_signals=True, disable_rostime=lockstep
            )
            if isinstance(self.clock, LockstepClock):
                self.clock.on_advance.append(self._set_rostime)
                self._set_rostime()
        WATCH.start(self)

    def _set_rostime(self) -> None:
        rospy.rostime._set_rostime(rospy.Time.from_sec(self.clock.now()))

    @property
    def ros_name(self) -> str:
        """This process's rospy node name: the sender of every message its nodes publish."""
        return normalize_node_name(rospy.get_name())

    def node(self, name: str) -> RosNode:
        """A logical node (see :meth:`Transport.node`); the first one initialises the rospy node."""

        def make(free: str) -> RosNode:
            self._ensure_init(free)
            return RosNode(self, free)

        return self._add_node(name, make)

    def close(self) -> None:
        """See :meth:`Transport.close`; rospy refuses late connections quietly meanwhile
        (:func:`~cyborg.transport.ros.patches.refusing_late_connections`)."""
        if self._closed:
            return
        with patches.refusing_late_connections():
            self.shutdown()
        super().close()

    def _leave(self) -> None:
        """Leave the graph: rospy shuts down, and cannot rejoin it in this process."""
        rospy.signal_shutdown("cyborg node stopped")

    def wait_for_connections(self, timeout: float) -> list[str]:
        """See :meth:`Transport.wait_for_connections` and :mod:`.connections`."""
        if not rospy.core.is_initialized():
            return []
        from cyborg.transport.ros.connections import wait_for_connections

        return [f"{missing} on {missing.topic}" for missing in wait_for_connections(timeout)]

    def graph(self, *, ask_nodes: bool = True) -> GraphView:
        """The master's graph, each node asked whether it answers unless ``ask_nodes`` is False
        (see :mod:`.graph`)."""
        from cyborg.transport.ros.graph import ros1_graph

        return ros1_graph(ask_nodes=ask_nodes)

    def subscribers_of(self, topic: str) -> list[str]:
        """The nodes the master lists as subscribers of ``topic`` (empty if it does not answer)."""
        return listed_subscribers(topic)

    def subscription_endpoints(self, topic: str) -> int:
        """The subscriber connections a publisher of ``topic`` makes: one for each listed node."""
        return len(listed_subscribers(topic))

    def set_param(self, key: str, value: Any) -> None:
        """Set a parameter on the master, skipping the round trip when it already holds ``value``.

        A master call is an XML-RPC request (about 1 ms on loopback) made on the loop, and the
        controller sets ``/state_resources`` on every handover, often to the value it already has.
        After its first set this process subscribes to the parameter, so the master reports
        other nodes' changes to it (``paramUpdate``); such a change forgets the remembered value.

        While the master does not answer, this logs it (once) and returns: the value is set when
        the master is back, as is every parameter this process set last (a restarted master holds
        none), unless another node set it since.
        """
        WATCH.want(key, value)  # first: our own set's update notice must find it ours
        with self._params_lock:
            known = self._param_values.get(key, _UNKNOWN)
        if known is not _UNKNOWN and known == value:
            return
        try:
            rospy.set_param(key, copy.deepcopy(value))  # rospy's cache keeps what it is given
            if key not in self._watched_params:
                self._watched_params.add(key)
                WATCH.follow(key)
                cache = rospy.impl.paramserver.get_param_server_cache()
                if cache.notifier != self._on_param_update:
                    self._chained_notifier = cache.notifier
                    cache.set_notifier(self._on_param_update)
                # Subscribes. An empty dict reads as "unset" in rospy's cache: hence the default.
                rospy.get_param_cached(key, None)
        except UNREACHABLE as exc:
            WATCH.missed(f"set {key}", exc)
            return
        with self._params_lock:
            self._param_values[key] = copy.deepcopy(value)

    def forget_param_values(self) -> None:  # the master watch's thread: a new master holds nothing
        with self._params_lock:
            self._param_values.clear()

    def _on_param_update(self, key: str, value: Any) -> None:  # rospy thread, under the cache's lock
        """A subscribed parameter changed (our own set comes here first, then records its value)."""
        changed = key.rstrip("/") + "/"
        with self._params_lock:
            for watched in list(self._param_values):
                if changed.startswith(watched + "/") or (watched + "/").startswith(changed):
                    del self._param_values[watched]
        WATCH.changed_elsewhere(key, value)
        if self._chained_notifier is not None:
            self._chained_notifier(key, value)


class RosNode(Node):
    """One logical node: the components of a process share its one rospy node."""

    def __init__(self, transport: RosTransport, name: str) -> None:
        super().__init__(transport, name)
        self.transport = transport

    def publisher(
        self, topic: str, msg_type: type[M], *, queue_size: int = DEFAULT_QUEUE_SIZE, latch: bool = False
    ) -> Publisher[M]:
        check_topic_type(self.resolve(topic), msg_type)
        pub = RosPublisher[M](self.transport, self.resolve(topic), msg_type, queue_size, latch)
        self.on_shutdown(pub.unregister)
        return pub

    def subscribe(
        self,
        topic: str,
        msg_type: type[M],
        callback: Callable[[M, MessageInfo], Awaitable[None] | None],
        *,
        queue_size: int = DEFAULT_QUEUE_SIZE,
    ) -> Subscription[M]:
        check_topic_type(self.resolve(topic), msg_type)
        sub = RosSubscription(self.transport, self.resolve(topic), msg_type, callback, queue_size)
        self.on_shutdown(sub.unsubscribe)
        return sub

    def advertise_service(
        self,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
    ) -> ServiceServer:
        server = RosServiceServer(self.transport, self.resolve(name), srv_type, handler)
        self.on_shutdown(server.shutdown)
        return server

    def service_proxy(self, name: str, srv_type: ServiceType[Req, Resp]) -> ServiceProxy[Req, Resp]:
        return RosServiceProxy(self.transport, self.resolve(name), srv_type)

    def action_server(
        self,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
    ) -> ActionServer[G, R, F]:
        server = RosActionServer(self.transport, self.resolve(name), action_type, on_goal, on_cancel)
        self.on_shutdown(server.shutdown)
        return server

    def action_client(self, name: str, action_type: ActionType[G, R, F]) -> ActionClient[G, R, F]:
        client = RosActionClient(self.transport, self.resolve(name), action_type)
        self.on_shutdown(client.close)
        return client

    def get_param(self, name: str, default: Any = None) -> Any:
        key = self.resolve(name)
        try:
            return rospy.get_param(key, default)
        except UNREACHABLE as exc:
            raise TransportError(
                f"could not read the parameter {key}: the ROS master at {rosgraph.get_master_uri()} does "
                f"not answer ({exc}); fix: start roscore again on the same port (the nodes register again)"
            ) from exc

    def set_param(self, name: str, value: Any) -> None:
        self.transport.set_param(self.resolve(name), value)
