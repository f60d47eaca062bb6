"""Waiting for rospy's connections before a node starts (cyborg.transport.ros.connections).

rospy connects subscribers to publishers on its own threads; a connection it dropped or never
made is never tried again, and what is published meanwhile is lost without an error. A node
waits for its connections before it starts, registers again what is missing, and names what
is still missing.
"""

from __future__ import annotations

import time
import xmlrpc.client

from cyborg.testing.wait import wait_until
from cyborg.transport.messages import String
from tests.support.ros import RosSession


def test_a_dropped_subscription_is_connected_again_and_then_hears_the_first_message(ros: RosSession) -> None:
    from rospy.impl.registration import get_topic_manager  # type: ignore[import-not-found]

    topic = "/cyborg_test/connections/dropped"
    talker, listener = ros.transport.node("conn_talker"), ros.transport.node("conn_listener")
    got: list[str] = []
    listener.subscribe(topic, String, lambda m, i: got.append(m.data))
    pub = talker.publisher(topic, String)
    try:
        assert ros.transport.wait_for_connections(10.0) == []
        assert pub.subscriber_count() == 1

        # What rospy does when a connection attempt fails: the connection is gone and stays gone.
        impl = get_topic_manager().get_subscriber_impl(topic)
        for connection in list(impl.connections):
            connection.close()
        assert ros.clock.run(wait_until(lambda: pub.subscriber_count() == 0, ros.clock, timeout=5.0))
        missing = ros.transport.wait_for_connections(0.0)
        assert any(topic in m for m in missing), missing

        assert ros.transport.wait_for_connections(10.0) == []  # registered again: connected
        assert pub.subscriber_count() == 1

        async def heard() -> bool:
            pub.publish(String("first"))
            return await wait_until(lambda: got == ["first"], ros.clock, timeout=5.0)

        assert ros.clock.run(heard()), got
    finally:
        talker.shutdown()
        listener.shutdown()


def test_a_listed_publisher_that_is_gone_is_named_and_the_wait_ends(ros: RosSession) -> None:
    import rosgraph  # type: ignore[import-not-found]

    topic = "/cyborg_test/connections/ghost"
    listener = ros.transport.node("conn_ghost_listener")
    listener.subscribe(topic, String, lambda m, i: None)
    master = xmlrpc.client.ServerProxy(rosgraph.get_master_uri())
    # A node killed without unregistering: the master still lists it, at an address nobody answers.
    ghost, ghost_uri = "/cyborg_test_ghost", "http://localhost:9/"
    master.registerPublisher(ghost, topic, "std_msgs/String", ghost_uri)
    try:
        started = time.monotonic()
        missing = ros.transport.wait_for_connections(1.5)
        waited = time.monotonic() - started
        assert missing == [f"{ghost.lstrip('/')} -> {ros.transport.ros_name} on {topic}"]
        assert 1.5 <= waited < 10.0
    finally:
        master.unregisterPublisher(ghost, topic, ghost_uri)
        listener.shutdown()
