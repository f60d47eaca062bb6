"""Topics of the ROS 2 transport: publishers and subscriptions on rclpy, and who sent a message.

Part of :mod:`cyborg.transport.ros2`. Every received message names its sender, as under ROS 1:
rclpy (Kilted) gives each message its publisher's GID, and the graph lists the GID of every
publisher of a topic with its node's name (:class:`Senders`). A publisher the graph does not
know yet (or whose node it names ``_NODE_NAME_UNKNOWN_``: the node's discovery lags its
publisher's) is looked up again for up to SENDER_LOOKUP seconds; after that the sender is '' (a
gatekeeper drops such a message: it fails closed).

Latched topics are transient-local (the last message kept for late subscribers, depth 1). A
transient-local subscription matches only transient-local publishers, and a volatile one
every publisher, so each subscription is two: volatile (live messages from every publisher)
and transient-local (what latched publishers kept). A message both deliver is taken once: per
publisher, only a publication sequence number above the last one taken passes.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from typing import Any

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.duration import Duration
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.exceptions import InvalidHandle
from rclpy.node import Node as RclNode
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from cyborg.transport._queue import SubscriptionQueue
from cyborg.transport.base import M, MessageInfo, Publisher, Subscription, normalize_node_name
from cyborg.transport.ros2.convert import from_ros2, ros2_class, to_ros2
from cyborg.transport.ros2.host import Host

__all__ = ["SENDER_LOOKUP", "Ros2Publisher", "Ros2Subscription", "Senders", "latched_qos", "volatile_qos"]

UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"  # what the graph names an endpoint whose node it does not know yet
SEEN_KEPT = 4096  # messages remembered to drop the second copy of (both halves deliver each)
SENDER_LOOKUP = 0.5  # seconds a publisher unknown to the graph is waited for, from its first message
# Lockstep time stands still meanwhile, and a message of an unnamed sender is dropped by a
# gatekeeper: on a loaded machine the graph may name a publisher seconds after its first message.
LOCKSTEP_SENDER_LOOKUP = 10.0

log = logging.getLogger(__name__)


def volatile_qos(depth: int) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
    )


def latched_qos(depth: int = 1) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )


class Senders:
    """Node names of a topic's publishers by GID, from the graph (refreshed on a miss).

    A publisher the graph cannot name is waited for up to SENDER_LOOKUP seconds from its first
    message, not from each one: a flood from it costs that wait once (one executor thread
    waiting 0.5 s per message held the subscription's delivery up for many seconds).
    """

    def __init__(self, node: RclNode, topic: str, *, lookup: float = SENDER_LOOKUP) -> None:
        self._node = node
        self._topic = topic
        self._lookup = lookup
        self._names: dict[bytes, str] = {}
        self._deadlines: dict[bytes, float] = {}  # GID -> until when a miss is looked up again
        self._lock = threading.Lock()

    def name_of(self, gid: bytes) -> str:
        with self._lock:
            name = self._names.get(gid)
            if name is not None:
                return name
            deadline = self._deadlines.setdefault(gid, time.monotonic() + self._lookup)
        while True:
            names = {
                bytes(info.endpoint_gid): normalize_node_name(info.node_name)
                for info in self._node.get_publishers_info_by_topic(self._topic)
                if info.node_name != UNKNOWN_NODE  # its node's name not discovered yet: a miss
            }
            with self._lock:
                self._names = names
            if gid in names or time.monotonic() >= deadline:
                return names.get(gid, "")
            time.sleep(0.005)


class Ros2Publisher(Publisher[M]):
    def __init__(
        self, transport: Host, node: RclNode, topic: str, msg_type: type[M], queue_size: int, latch: bool
    ) -> None:
        self.topic = topic
        self._stats = transport.stats
        self._ledger = transport.clock.ledger
        self._cls = ros2_class(msg_type.ros_type)
        qos = latched_qos() if latch else volatile_qos(queue_size)
        self._node = node
        # Every subscription of ours has a transient-local half that a volatile publisher does
        # not serve, by design (module docstring): no warning about it. Nor an event handler: each
        # is one more entity in the executor's wait set, built anew in Python for every message
        # the process hears (a subscription warns of a type or QoS that does not fit).
        self._pub: Any = node.create_publisher(
            self._cls, topic, qos, event_callbacks=PublisherEventCallbacks(use_default_callbacks=False)
        )

    def publish(self, message: M) -> None:
        """Send ``message`` (latched: transient-local); nothing once unregistered."""
        if self._pub is None:
            return  # unregistered (its node shut down): a late publish while a process stops goes nowhere
        self._pub.publish(to_ros2(message, self._cls))
        self._stats.published += 1
        if self._ledger is not None:
            self._ledger.sent(self.topic)

    def subscriber_count(self) -> int:
        """The subscriptions DDS has matched with this publisher so far."""
        return 0 if self._pub is None else int(self._pub.get_subscription_count())

    def wait_delivered(self, timeout: float) -> bool:
        """Until every matched subscription acknowledged what was published (reliable QoS)."""
        if self._pub is None:
            return False
        return bool(self._pub.wait_for_all_acked(Duration(nanoseconds=int(timeout * 1e9))))

    def unregister(self) -> None:
        """Leave the topic (its node's shutdown does this); a second call does nothing."""
        publisher, self._pub = self._pub, None
        if publisher is not None:
            self._node.destroy_publisher(publisher)


class Ros2Subscription(Subscription[M]):
    """Two rclpy subscriptions (volatile and transient-local) feeding the shared bounded queue."""

    def __init__(
        self,
        transport: Host,
        node: RclNode,
        topic: str,
        msg_type: type[M],
        callback: Callable[[M, MessageInfo], Awaitable[None] | None],
        queue_size: int,
        callback_group: Any,  # unused: each subscription has a mutually exclusive group of its own
    ) -> None:
        self.topic = topic
        self._transport = transport
        self._node = node
        self._type = msg_type
        self._queue = SubscriptionQueue(
            transport.clock, callback, queue_size, transport.run_callback, transport.stats
        )
        lookup = LOCKSTEP_SENDER_LOOKUP if transport.clock.is_lockstep else SENDER_LOOKUP
        self._senders = Senders(node, topic, lookup=lookup)
        self._ledger = transport.clock.ledger
        if self._ledger is not None:
            self._ledger.listen(topic)
        # What the two halves delivered lately: a message comes from both, once from each. Keyed
        # by the writer, its sequence number and its time: a process that makes a new publisher
        # may get a writer id used before, whose numbers start again at 1.
        self._seen: OrderedDict[tuple[bytes, int, int], None] = OrderedDict()
        self._lock = threading.Lock()
        cls = ros2_class(msg_type.ros_type)
        # One at a time and in order: the executor has many threads, and a message taken after a
        # later one of the same publisher would count as a duplicate.
        callback_group = MutuallyExclusiveCallbackGroup()
        depth = max(queue_size * 4, 100)  # DDS keeps more than our queue: our queue counts the drops
        self._subs = [
            node.create_subscription(
                cls, topic, self._on_ros, volatile_qos(depth), callback_group=callback_group
            ),
            # A volatile publisher does not match this one, by design: no warning about it; the
            # volatile half warns of a type that does not fit. No event handler, then: each is one
            # more entity in the wait set the executor builds in Python for every message heard.
            node.create_subscription(
                cls,
                topic,
                self._on_ros,
                latched_qos(depth),
                callback_group=callback_group,
                event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False),
            ),
        ]

    @property
    def dropped(self) -> int:
        """Messages dropped because the bounded queue was full."""
        return self._queue.dropped

    def _on_ros(self, ros_message: Any, ros_info: Any) -> None:  # executor thread
        try:
            self._take(ros_message, ros_info)
        except InvalidHandle:  # the node is being destroyed under a message still coming in
            log.debug("%s: message dropped, its subscription is closing", self.topic)
        except Exception:  # never into rclpy's executor, which stops spinning on it
            log.exception("%s: could not take a message; the subscription carries on", self.topic)

    def _take(self, ros_message: Any, ros_info: Any) -> None:
        gid_info = ros_info.get("publisher_gid") or {}
        gid = bytes(gid_info.get("data", b""))
        sequence = ros_info.get("publication_sequence_number")
        with self._lock:  # taken once, in order, whichever of the two delivers it first
            if gid and sequence is not None:
                key = (gid, int(sequence), int(ros_info.get("source_timestamp") or 0))
                if key in self._seen:
                    return
                self._seen[key] = None
                if len(self._seen) > SEEN_KEPT:
                    self._seen.popitem(last=False)
            sender = self._senders.name_of(gid) if gid else ""
            info = MessageInfo(sender=sender, stamp=time.time())
            message = from_ros2(ros_message, self._type)
            self._transport.arrive(self.topic, sender, self._queue.put, message, info, counted=(self.topic,))

    def unsubscribe(self) -> None:
        """Deliver nothing more and destroy both rclpy subscriptions."""
        self._queue.close()
        for sub in self._subs:
            self._node.destroy_subscription(sub)
        if self._subs and self._ledger is not None:
            self._ledger.unlisten(self.topic)
        self._subs = []
