"""Topics of the ROS 1 transport: publishers and subscriptions on rospy.

Part of :mod:`cyborg.transport.ros`. A subscription hands what rospy receives, on rospy's
threads, to the shared bounded :class:`~cyborg.transport._queue.SubscriptionQueue` on the
clock's event loop. :func:`check_topic_type` refuses a second message type on a topic, as the
embedded transport does.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Awaitable, Callable
from typing import Any

import rosgraph  # type: ignore[import-not-found]
import rospy  # type: ignore[import-not-found]

from cyborg.errors import TransportError
from cyborg.transport._host import Host
from cyborg.transport._queue import SubscriptionQueue
from cyborg.transport.base import M, MessageInfo, Publisher, Subscription
from cyborg.transport.messages import Message
from cyborg.transport.ros import reads
from cyborg.transport.ros.convert import from_ros, ros_class, sender, to_ros
from cyborg.transport.ros.master import listed_subscribers

__all__ = ["FRESH_PUBLISHER_WAIT", "RosPublisher", "RosSubscription", "check_topic_type"]

log = logging.getLogger(__name__)

FRESH_PUBLISHER_WAIT = 1.0  # seconds a new publisher's messages may wait for known subscribers


def check_topic_type(topic: str, msg_type: type[Message]) -> None:
    """Refuse a second message type on a topic, as the embedded transport does.

    rospy itself accepts it silently (in this process the second type is simply ignored;
    across processes the connections fail on the md5 sum). Checked against this
    process's publishers and subscribers and against the master's current publishers.
    """
    from rospy.impl.registration import Registration, get_topic_manager  # type: ignore[import-not-found]

    wanted = msg_type.ros_type
    manager = get_topic_manager()
    known = None
    for kind in (Registration.PUB, Registration.SUB):
        impl = manager.get_impl(kind, topic) if manager is not None else None
        if impl is not None and impl.type:
            known = impl.type
            break
    if known is None:
        try:
            published = rosgraph.Master(rospy.get_name()).getPublishedTopics("")
        except Exception:  # the master is asked only to give a clearer error
            log.debug("could not ask the master for the type of %s", topic, exc_info=True)
            published = []
        known = next((t for name, t in published if name == topic), None)
    if known not in (None, "*", wanted):
        raise TransportError(
            f"topic {topic} carries {known}, not {wanted}: "
            "use the same message type on every publisher and subscriber of a topic"
        )


class RosPublisher(Publisher[M]):
    """A rospy publisher whose first messages wait for the subscribers the master already knows.

    A subscriber connects to a new publisher only after the master told it about it (Python's
    rosmaster hands such notices to workers that look for work every 0.1 s), so rospy drops what
    a publisher made on the spot sends at once (a module's first sentence). For
    FRESH_PUBLISHER_WAIT seconds after it is made, a message sent while fewer subscribers are
    connected than the master lists waits, on a thread, until they are (or that time is up);
    later messages queue behind it, so the order holds.
    """

    def __init__(self, transport: Host, topic: str, msg_type: type[M], queue_size: int, latch: bool) -> None:
        self.topic = topic
        self._stats = transport.stats
        self._ledger = transport.clock.ledger
        self._cls = ros_class(msg_type.ros_type)
        self._pub = rospy.Publisher(topic, self._cls, queue_size=queue_size, latch=latch)
        self._fresh_until = time.monotonic() + FRESH_PUBLISHER_WAIT
        self._expected: int | None = None
        self._pending: deque[Any] | None = None
        self._lock = threading.Lock()

    def publish(self, message: M) -> None:
        """Send ``message``; while the publisher is fresh, it may wait for known subscribers (above)."""
        ros_message = to_ros(message, self._cls)
        self._stats.published += 1
        if self._ledger is not None:
            self._ledger.sent(self.topic)
        with self._lock:
            if self._pending is not None:
                self._pending.append(ros_message)
                return
            if time.monotonic() < self._fresh_until and self._missing_subscribers():
                self._pending = deque([ros_message])
                threading.Thread(target=self._flush_when_connected, name=f"publish {self.topic}").start()
                return
        self._pub.publish(ros_message)

    def _missing_subscribers(self) -> bool:
        if self._expected is None:
            self._expected = len(listed_subscribers(self.topic))
        return int(self._pub.get_num_connections()) < self._expected

    def _flush_when_connected(self) -> None:
        assert self._expected is not None
        while time.monotonic() < self._fresh_until and self._pub.get_num_connections() < self._expected:
            time.sleep(0.002)
        with self._lock:
            pending, self._pending = self._pending or deque(), None
            for ros_message in pending:  # under the lock: a publish meanwhile queues behind these
                self._pub.publish(ros_message)

    def subscriber_count(self) -> int:
        """The subscribers connected to this publisher now."""
        return int(self._pub.get_num_connections())

    def unregister(self) -> None:
        """Leave the topic (its node's shutdown does this)."""
        self._pub.unregister()


class RosSubscription(Subscription[M]):
    """A rospy subscriber feeding the shared bounded queue (rospy's own queue is unbounded)."""

    def __init__(
        self,
        transport: Host,
        topic: str,
        msg_type: type[M],
        callback: Callable[[M, MessageInfo], Awaitable[None] | None],
        queue_size: int,
    ) -> None:
        self.topic = topic
        self._transport = transport
        self._type = msg_type
        self._queue = SubscriptionQueue(
            transport.clock, callback, queue_size, transport.run_callback, transport.stats
        )
        self._ledger = transport.clock.ledger
        if self._ledger is not None:
            self._ledger.listen(topic)
        reads.mark(self, transport.clock)  # read on the loop (in real time)
        self._sub = rospy.Subscriber(topic, ros_class(msg_type.ros_type), self._on_ros, queue_size=None)

    @property
    def dropped(self) -> int:
        """Messages dropped because the bounded queue was full."""
        return self._queue.dropped

    def _on_ros(self, ros_message: Any) -> None:  # rospy's thread, or the loop (reads.py)
        info = MessageInfo(sender=sender(ros_message), stamp=time.time())
        message = from_ros(ros_message, self._type)
        self._transport.arrive(self.topic, info.sender, self._queue.put, message, info, counted=(self.topic,))

    def unsubscribe(self) -> None:
        """Deliver nothing more and leave the topic."""
        self._queue.close()
        self._sub.unregister()
        if self._ledger is not None:
            self._ledger.unlisten(self.topic)
