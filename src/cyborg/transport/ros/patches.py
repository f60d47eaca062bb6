"""Changes to rospy's own behaviour, made by :func:`install` when a RosTransport is created.

Part of the ROS 1 transport (:mod:`cyborg.transport.ros`). Importing this module (or the
transport) changes nothing; :func:`install` patches rospy's classes for the whole process, once
(calling it again does nothing):

* every subscriber, actionlib's own included, asks for TCP_NODELAY;
* registering a new publisher, subscriber or service calls the master once instead of until it
  answers, leaving the rest to :data:`~cyborg.transport.ros.master.WATCH`;
* a publisher with a queue (ours, actionlib's) writes a message in the publishing thread when the
  socket takes it without blocking, instead of always through a writer thread
  (:mod:`.writes`);
* a subscriber connection whose callbacks all belong to one event loop's components is read on
  that loop instead of on a thread per connection (:mod:`.reads`);
* rospy's own threads wake less often in an idle node: its registration thread (which also
  drops closed connections) every REGISTRATION_PERIOD seconds instead of every 0.5 s, its
  XML-RPC server's loop every XMLRPC_POLL_PERIOD seconds instead of every 0.5 s (it answers a
  call at once either way; the period only times a ``shutdown()`` that rospy never calls). With
  the master watch and the status timer they woke an idle node 7 times a second; sixteen
  processes of a launched robot, about half a percent of a core together.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator
from typing import Any

import rospy  # type: ignore[import-not-found]

from cyborg.transport.ros import reads
from cyborg.transport.ros.master import UNREACHABLE, WATCH, answer, master_proxy

__all__ = ["REGISTRATION_PERIOD", "XMLRPC_POLL_PERIOD", "install", "refusing_late_connections"]

REGISTRATION_PERIOD = 2.0
"""Seconds between two rounds of rospy's registration thread with nothing to do (rospy: 0.5). A
round also drops the connections of a subscriber that went away (rospy's ``check_all``), so this
stays below the 3 s after which a silent action server counts as gone."""
XMLRPC_POLL_PERIOD = 30.0
"""Seconds between two looks of rospy's XML-RPC server loop at a shutdown request (rospy: 0.5)."""


def install() -> None:
    """Patch rospy for this process (idempotent)."""
    _ask_for_tcp_nodelay()
    _register_once()
    _write_at_once()
    _calm_idle_threads()
    reads.install()


def _write_at_once() -> None:
    """Make every queued publisher connection made from now on a :class:`WriteAtOnceConnection`."""
    import rospy.topics  # type: ignore[import-not-found]

    from cyborg.transport.ros.writes import WriteAtOnceConnection

    rospy.topics.QueuedConnection = WriteAtOnceConnection


class _PatientCondition(threading.Condition):
    """rospy's registration thread's condition: a timed wait lasts at least REGISTRATION_PERIOD
    (a notify, for a new publisher or at shutdown, still ends it at once)."""

    def wait(self, timeout: float | None = None) -> bool:
        return super().wait(None if timeout is None else max(timeout, REGISTRATION_PERIOD))


def _calm_idle_threads() -> None:
    """Make rospy's registration thread and XML-RPC server loop wake less often (module docstring)."""
    import rosgraph.xmlrpc  # type: ignore[import-not-found]
    from rospy.impl.registration import RegManager  # type: ignore[import-not-found]

    original_init = RegManager.__init__
    if getattr(original_init, "_cyborg_calm", False):
        return

    def init(self: Any, *args: Any, **kwargs: Any) -> None:
        original_init(self, *args, **kwargs)
        cond = self.cond = _PatientCondition()

        def wake(reason: str) -> None:  # rospy's shutdown joins the thread: it must see the flag now
            with cond:
                cond.notify_all()

        rospy.core.add_shutdown_hook(wake)

    init._cyborg_calm = True  # type: ignore[attr-defined]
    RegManager.__init__ = init
    server = rosgraph.xmlrpc.ThreadingXMLRPCServer
    serve_forever = server.serve_forever

    def serve(self: Any, poll_interval: float = XMLRPC_POLL_PERIOD) -> None:
        serve_forever(self, max(poll_interval, XMLRPC_POLL_PERIOD))

    server.serve_forever = serve


def _ask_for_tcp_nodelay() -> None:
    """Make every subscriber (actionlib's own included) ask for TCP_NODELAY.

    Without it small messages wait for Nagle's algorithm: about 40 ms stalls per handover.
    """
    original = rospy.topics.Subscriber.__init__
    if getattr(original, "_cyborg_nodelay", False):
        return

    def init(self: Any, *args: Any, tcp_nodelay: bool = True, **kwargs: Any) -> None:
        original(self, *args, tcp_nodelay=tcp_nodelay, **kwargs)

    init._cyborg_nodelay = True  # type: ignore[attr-defined]
    rospy.topics.Subscriber.__init__ = init


def _register_once() -> None:
    """Make rospy register a new publisher, subscriber or service without waiting for the master.

    rospy's ``RegManager.reg_added`` calls the master again every 0.2 s until it answers, on the
    thread that made the publisher (in our nodes the event loop: a controller entering a state
    during an outage would stop there) and under rospy's topic lock. This one calls it once; if the
    master does not answer, the master watch registers it with everything else when it is back.
    (In a process where no watch runs, i.e. no RosTransport made a node, rospy's own way is kept.)
    """
    from rospy.impl.registration import Registration, RegManager  # type: ignore[import-not-found]

    original = RegManager.reg_added
    if getattr(original, "_cyborg_once", False):
        return

    def reg_added(self: Any, resolved_name: str, data_type_or_uri: str, reg_type: str) -> None:
        if not self.master_uri or not WATCH.running:  # (plain rospy use: nobody would register it later)
            original(self, resolved_name, data_type_or_uri, reg_type)
            return
        proxy = master_proxy(self.master_uri)
        args = (rospy.names.get_caller_id(), resolved_name, data_type_or_uri, self.uri)
        try:
            if reg_type == Registration.PUB:
                answer(proxy.registerPublisher(*args), f"register publisher {resolved_name}")
            elif reg_type == Registration.SUB:
                publishers = answer(proxy.registerSubscriber(*args), f"register subscriber {resolved_name}")
                if publishers:
                    self.publisher_update(resolved_name, publishers)
            elif reg_type == Registration.SRV:
                answer(proxy.registerService(*args), f"register service {resolved_name}")
        except UNREACHABLE as exc:
            WATCH.missed(f"register {resolved_name}", exc)

    reg_added._cyborg_once = True  # type: ignore[attr-defined]
    RegManager.reg_added = reg_added


@contextlib.contextmanager
def refusing_late_connections() -> Iterator[None]:
    """While the block runs (a process's nodes unregister as it stops), rospy answers a subscriber
    that connects late, not told yet that a publisher is gone, "node shutting down" quietly, as it
    does once its own shutdown has begun, instead of a warning on the terminal ("... is not a
    publisher of ..."). Afterwards rospy's shutdown runs as before."""
    import rospy.core  # type: ignore[import-not-found]

    if rospy.core.is_shutdown_requested():
        yield
        return
    rospy.core._in_shutdown = True
    try:
        yield
    finally:
        rospy.core._in_shutdown = False
