"""Waiting until this process's topics are connected to every peer the master lists.

Part of the ROS 1 transport (:mod:`cyborg.transport.ros`). rospy connects a subscriber to a
publisher on its own threads some time after both registered: the master tells the subscriber,
which asks the publisher's XML-RPC server for a port, then opens a TCP connection. What is
published before that is lost to that subscriber, with no error anywhere. A node that starts a
run (``cyborg node`` under ``cyborg launch``) first waits here, so that the run's first messages
(the controller's first state, which the motivator in its own process must hear to ever decide)
reach everyone who subscribed.

The master lists node names; rospy's connections name their peer node (the publisher's
``callerid`` from its header, the subscriber's from the header it sent), so both are compared by
node name. A subscription still missing a publisher after :data:`RECONNECT_AFTER` seconds is
registered again, which hands rospy the publishers' addresses once more: rospy gives up on a
publisher whose XML-RPC server refused a connection and never tries it again by itself.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any

import rosgraph  # type: ignore[import-not-found]
import rospy  # type: ignore[import-not-found]

from cyborg.transport.base import normalize_node_name
from cyborg.transport.ros.master import UNREACHABLE, master_proxy, register_subscriber

__all__ = ["RECONNECT_AFTER", "Unconnected", "unconnected", "wait_for_connections"]

log = logging.getLogger(__name__)

RECONNECT_AFTER = 1.0  # seconds a subscription may miss a listed publisher before it registers again
POLL_PERIOD = 0.1  # seconds between two looks at the master's lists and rospy's connections

# rospy's own: its log topic, connected by rospy itself to the rosout node.
_RUNTIME_TOPICS = frozenset({"/rosout"})


@dataclass(frozen=True)
class Unconnected:
    """``node`` is listed on ``topic`` as a publisher (``subscriber`` False: it publishes what this
    process subscribes to) or a subscriber, and this process has no connection with it yet."""

    topic: str
    node: str
    subscriber: bool

    def __str__(self) -> str:
        me = normalize_node_name(rospy.get_name())
        return f"{me} -> {self.node}" if self.subscriber else f"{self.node} -> {me}"


def _peers(connections: list[Any], attribute: str) -> set[str]:
    return {normalize_node_name(str(getattr(c, attribute, ""))) for c in connections if not c.done}


def unconnected(system_state: Any) -> list[Unconnected]:
    """This process's topics and the listed peers they are not connected to, from the master's
    ``getSystemState`` answer."""
    from rospy.impl.registration import get_topic_manager  # type: ignore[import-not-found]

    publishers_listed, subscribers_listed, _ = system_state
    listed_pub = {topic: {normalize_node_name(n) for n in nodes} for topic, nodes in publishers_listed}
    listed_sub = {topic: {normalize_node_name(n) for n in nodes} for topic, nodes in subscribers_listed}
    manager = get_topic_manager()
    missing: list[Unconnected] = []
    # (the peers listed subscribe?, this process's topics, rospy's impl of one, the peers listed per
    # topic, the attribute naming a connection's peer)
    sides = (
        (False, manager.get_subscriptions(), manager.get_subscriber_impl, listed_pub, "callerid_pub"),
        (True, manager.get_publications(), manager.get_publisher_impl, listed_sub, "endpoint_id"),
    )
    for peer_subscribes, registered, impl_of, listed, peer_name in sides:
        for topic, _type in registered:
            impl = impl_of(topic)
            if impl is None or topic in _RUNTIME_TOPICS:
                continue
            have = _peers(impl.connections, peer_name)
            missing += [
                Unconnected(topic, n, peer_subscribes) for n in sorted(listed.get(topic, set()) - have)
            ]
    return missing


def _register_again(topics: set[str]) -> None:
    """Register these subscriptions again: rospy then connects to the listed publishers it lacks."""
    from rospy.impl.registration import get_topic_manager  # type: ignore[import-not-found]

    types = dict(get_topic_manager().get_subscriptions())
    proxy = master_proxy()
    for topic in sorted(topics):
        register_subscriber(proxy, topic, types[topic])


def wait_for_connections(timeout: float) -> list[Unconnected]:
    """Wait up to ``timeout`` real seconds until every topic of this process is connected to every
    node the master lists on it; return what is still missing (empty: all connected).

    A listed node that is gone without unregistering (killed) stays missing until the timeout: the
    caller goes on and says so.
    """
    deadline = time.monotonic() + timeout
    missing_since: dict[str, float] = {}
    master = rosgraph.Master(rospy.get_name())
    missing: list[Unconnected] = []
    while True:
        now = time.monotonic()
        try:
            missing = unconnected(master.getSystemState())
        except UNREACHABLE as exc:
            log.debug("the master did not answer while waiting for connections: %s", exc)
        else:
            if not missing:
                return []
            lacking = {m.topic for m in missing if not m.subscriber}
            for topic in list(missing_since):
                if topic not in lacking:
                    del missing_since[topic]
            for topic in lacking:
                missing_since.setdefault(topic, now)
            overdue = {t for t, since in missing_since.items() if now - since >= RECONNECT_AFTER}
            if overdue:
                log.debug("subscribing again to %s: a listed publisher is not connected", ", ".join(overdue))
                try:
                    _register_again(overdue)
                except UNREACHABLE as exc:
                    log.debug("registering again failed: %s", exc)
                for topic in overdue:
                    missing_since[topic] = now
        if now >= deadline:
            return missing
        time.sleep(POLL_PERIOD)
