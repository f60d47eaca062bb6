"""The ROS master: calls to it that give up, and living through its outage or restart.

Part of the ROS 1 transport (:mod:`cyborg.transport.ros`). :data:`WATCH`, one
:class:`MasterWatch` per process, started by the first :class:`~.transport.RosTransport`
node, keeps everything this process registered (through rospy's registration internals) and
the parameters it set on the master while the master goes away and comes back.
:func:`listed_subscribers` asks the master who subscribes to a topic.
"""

from __future__ import annotations

import contextlib
import copy
import http.client
import logging
import os
import select
import threading
import time
import urllib.parse
import weakref
import xmlrpc.client
from typing import Any, Protocol

import rosgraph  # type: ignore[import-not-found]
import rospy  # type: ignore[import-not-found]

from cyborg.transport.base import normalize_node_name

__all__ = [
    "MASTER_CALL_TIMEOUT",
    "MASTER_CHECK_PERIOD",
    "MASTER_RECHECK_PERIOD",
    "UNREACHABLE",
    "WATCH",
    "MasterLine",
    "MasterWatch",
    "ParamHolder",
    "answer",
    "listed_subscribers",
    "master_proxy",
    "register_subscriber",
]

log = logging.getLogger(__name__)

MASTER_CHECK_PERIOD = 0.5  # seconds between two looks at the master while it is away or out of sync
MASTER_RECHECK_PERIOD = 15.0
"""Seconds between two looks at a master that answers: its going away is seen at once on the
line the watch keeps open to it (rosmaster speaks HTTP/1.1), this look is for a line that broke
without a word (another host's master, a cable pulled)."""
MASTER_CALL_TIMEOUT = 2.0  # seconds a call to the master may take before it counts as away
UNREACHABLE = (OSError, http.client.HTTPException, xmlrpc.client.Error)
"""What a call to a master that is not there (or not answering) raises."""


class _TimeoutTransport(xmlrpc.client.Transport):
    def __init__(self, timeout: float) -> None:
        super().__init__()
        self._timeout = timeout

    def make_connection(self, host: Any) -> http.client.HTTPConnection:
        connection = super().make_connection(host)
        connection.timeout = self._timeout
        return connection


def master_proxy(uri: str | None = None) -> xmlrpc.client.ServerProxy:
    """A proxy of the master for one thread, whose calls give up after MASTER_CALL_TIMEOUT."""
    return xmlrpc.client.ServerProxy(
        uri or rosgraph.get_master_uri(), transport=_TimeoutTransport(MASTER_CALL_TIMEOUT)
    )


def answer(reply: Any, what: str) -> Any:
    """The value of the master's ``(code, message, value)`` reply; a refusal is logged."""
    code, message, value = reply
    if code != 1:
        log.error("the ROS master refused to %s: %s", what, message)
    return value


def register_subscriber(proxy: xmlrpc.client.ServerProxy, topic: str, data_type: str) -> None:
    """Register this process's subscription of ``topic`` with the master (again: that changes
    nothing there) and hand rospy the publishers it lists: rospy connects to those it lacks."""
    from rospy.impl.registration import RegManager, get_registration_listeners  # type: ignore[import-not-found]

    caller, node_uri = rospy.get_name(), rospy.core.get_node_uri()
    publishers = answer(proxy.registerSubscriber(caller, topic, data_type, node_uri), f"register {topic}")
    manager = next((x for x in get_registration_listeners().listeners if isinstance(x, RegManager)), None)
    if manager is not None and publishers:
        manager.publisher_update(topic, publishers)


def listed_subscribers(topic: str) -> list[str]:
    """The nodes the master lists as subscribers of ``topic`` (empty if it does not answer)."""
    try:
        _, subscribers, _ = rosgraph.Master(rospy.get_name()).getSystemState()
    except Exception:
        return []
    return [normalize_node_name(n) for name, nodes in subscribers if name == topic for n in nodes]


class ParamHolder(Protocol):
    """Whoever remembers which parameter values the master holds (a RosTransport)."""

    def forget_param_values(self) -> None:
        """The master is a new one: it holds none of the values remembered."""


class MasterWatch:
    """Keeps this process's registrations on the ROS master through an outage or a restart of it.

    (The master going away and coming back are logged with rospy's logwarn: on the node's console,
    where rospy's own warnings go, and in its ROS log.)

    rospy tells the master of each publisher, subscriber and service once, when it is made, so a
    restarted master knows none of them (``rosnode list`` shows only /rosout) and no node that
    starts or subscribes afterwards finds them. Connections already made go on working (they do
    not pass through the master). This thread keeps a connection to the master open
    (:class:`MasterLine`) and sees at once when the master closes it; it asks the master for its
    pid then, every MASTER_RECHECK_PERIOD seconds besides, and every MASTER_CHECK_PERIOD seconds
    while the master is away or something could not be sent to it. When it does not answer, that is logged once; when it answers
    again (with a new pid after a restart), or after a registration or a parameter could not be
    sent meanwhile, everything rospy holds is registered again as rospy's own first registration
    does (publishers, subscribers and services; actions are topics), the parameters this process
    set are set again and the ones it follows are subscribed again. Registering again with the
    same master changes nothing. While the master is away, making a publisher, subscriber or
    service does not wait for it (see :mod:`cyborg.transport.ros.patches`): it is registered here
    when it is back.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._wanted: dict[str, Any] = {}  # parameter -> the value this process set last
        self._followed: set[str] = set()  # parameters whose changes this process is told of
        self._out_of_sync = threading.Event()
        self._transports: weakref.WeakSet[ParamHolder] = weakref.WeakSet()
        self._thread: threading.Thread | None = None
        self._pid: int | None = None
        self.away = False
        self.comebacks = 0
        self._wake_read, self._wake_write = -1, -1

    def start(self, transport: ParamHolder) -> None:
        self._transports.add(transport)
        if self._thread is not None:
            return
        try:
            self._pid = int(answer(master_proxy().getPid(rospy.get_name()), "give its pid"))
        except UNREACHABLE:
            self._out_of_sync.set()
        self._wake_read, self._wake_write = os.pipe()
        os.set_blocking(self._wake_read, False)
        os.set_blocking(self._wake_write, False)
        rospy.core.add_shutdown_hook(lambda reason: self._wake())
        self._thread = threading.Thread(target=self._run, name="ROS master watch", daemon=True)
        self._thread.start()

    def _wake(self) -> None:
        """Have the thread look now (rospy shuts down, or something could not reach the master)."""
        if self._wake_write >= 0:
            with contextlib.suppress(OSError):  # (full: a wake-up is pending anyway)
                os.write(self._wake_write, b"!")

    @property
    def running(self) -> bool:
        return self._thread is not None

    # what this process set and follows (any thread)
    def want(self, key: str, value: Any) -> None:
        with self._lock:
            self._wanted[key] = copy.deepcopy(value)

    def follow(self, key: str) -> None:
        with self._lock:
            self._followed.add(key)

    def changed_elsewhere(self, key: str, value: Any) -> None:
        """A followed parameter changed: a value another node set is no longer ours to set again."""
        changed = key.rstrip("/") + "/"
        with self._lock:
            for wanted in list(self._wanted):
                if wanted == key.rstrip("/") and self._wanted[wanted] == value:
                    continue  # our own set
                if changed.startswith(wanted + "/") or (wanted + "/").startswith(changed):
                    del self._wanted[wanted]

    def _went_away(self) -> bool:
        """Note that the master does not answer; True for the first notice of this outage."""
        with self._lock:
            first, self.away = not self.away, True
        return first

    def missed(self, what: str, exc: BaseException) -> None:
        """Something could not reach the master: it is sent when the master is back."""
        self._out_of_sync.set()
        self._wake()
        if self._went_away():
            rospy.logwarn(
                "could not %s: the ROS master at %s does not answer (%s); this node carries on with "
                "the connections it has and sends it when the master is back; fix: start roscore "
                "again on the same port",
                what,
                rosgraph.get_master_uri(),
                exc,
            )

    # the thread
    def _run(self) -> None:
        line = MasterLine(rosgraph.get_master_uri())
        last_look = -MASTER_RECHECK_PERIOD  # the first look opens the line
        while True:
            steady = not self.away and not self._out_of_sync.is_set()
            if steady:
                # Waiting on the kept-open line costs the master nothing: no call every half second
                # from every node (the idle robot's master was busiest with these). Nor this
                # process: the thread sleeps until the next look, the master closing the line, or
                # a wake-up (rospy shutting down, a call that missed the master).
                left = MASTER_RECHECK_PERIOD - (time.monotonic() - last_look)
                closed = left > 0 and line.wait_closed(left, wake=self._wake_read)
                if not closed and time.monotonic() - last_look < MASTER_RECHECK_PERIOD:
                    self._drain_wake()
                    if rospy.core.is_shutdown():
                        line.close()
                        return
                    continue
            else:
                time.sleep(MASTER_CHECK_PERIOD)
            if rospy.core.is_shutdown():
                line.close()
                return
            last_look = time.monotonic()
            try:
                self._check(line)
            except Exception:  # the watch must outlive any surprise
                log.exception(
                    "looking at the ROS master failed; looking again in %.1f s", MASTER_CHECK_PERIOD
                )

    def _drain_wake(self) -> None:
        if self._wake_read >= 0:
            with contextlib.suppress(OSError):  # (BlockingIOError: nothing to drain)
                os.read(self._wake_read, 512)

    def _check(self, line: MasterLine) -> None:
        uri = rosgraph.get_master_uri()
        try:
            pid = line.get_pid(rospy.get_name())
        except UNREACHABLE as exc:
            if self._went_away():
                rospy.logwarn(
                    "the ROS master at %s does not answer (%s); this node carries on with the "
                    "connections it has and registers again when the master is back; fix: start "
                    "roscore again on the same port",
                    uri,
                    exc,
                )
            return
        if pid == self._pid and not self.away and not self._out_of_sync.is_set():
            return
        restarted = pid != self._pid
        self._out_of_sync.clear()
        try:
            counts = self._register_all(master_proxy(uri))
        except UNREACHABLE as exc:
            self._out_of_sync.set()
            log.debug("registering again with the ROS master failed (%s); trying again", exc)
            return
        self._pid, was_away, self.away = pid, self.away, False
        self.comebacks += 1
        say = rospy.logwarn if restarted or was_away else log.info
        say(
            "the ROS master at %s is back%s: registered again %d publishers, %d subscribers, %d services, "
            "set %d parameters again",
            uri,
            " (restarted)" if restarted else "",
            *counts,
        )

    def _register_all(self, proxy: xmlrpc.client.ServerProxy) -> tuple[int, int, int, int]:
        from rospy.impl.registration import get_service_manager, get_topic_manager  # type: ignore[import-not-found]

        caller, node_uri = rospy.get_name(), rospy.core.get_node_uri()
        topics, services = get_topic_manager(), get_service_manager()
        with topics.lock, services.lock:  # as rospy's first registration: nothing added meanwhile
            publications, subscriptions = topics.get_publications(), topics.get_subscriptions()
            offered = services.get_services()
            for name, data_type in publications:
                answer(proxy.registerPublisher(caller, name, data_type, node_uri), f"register {name}")
            for name, data_type in subscriptions:
                register_subscriber(proxy, name, data_type)  # connects to any not connected yet
            for name, service_uri in offered:
                answer(proxy.registerService(caller, name, service_uri, node_uri), f"register {name}")
        for transport in list(self._transports):
            transport.forget_param_values()  # what the master held: a new one holds nothing
        with self._lock:
            wanted, followed = copy.deepcopy(self._wanted), set(self._followed)
        for key, value in wanted.items():
            answer(proxy.setParam(caller, key, value), f"set {key}")
        cache = rospy.impl.paramserver.get_param_server_cache()
        for key in followed:
            value = answer(proxy.subscribeParam(caller, node_uri, key), f"subscribe to {key}")
            cache.set(key, value)
        return len(publications), len(subscriptions), len(offered), len(wanted)


class MasterLine:
    """One HTTP/1.1 connection to the master, kept open between its ``getPid`` calls.

    rosmaster keeps such a connection open and idle, so the connection's socket turns readable
    (end of file) only when the master closes it: when it stops or restarts. Waiting on it
    (:meth:`wait_closed`) sees that at once, without asking the master anything.
    """

    def __init__(self, uri: str) -> None:
        parsed = urllib.parse.urlsplit(uri)
        self._host = parsed.hostname or "localhost"
        self._port = parsed.port or 11311
        self._path = parsed.path or "/"
        self._connection: http.client.HTTPConnection | None = None

    def get_pid(self, caller: str) -> int:
        """The master's pid (over the kept line; a new one when it is closed)."""
        connection = self._connection or http.client.HTTPConnection(
            self._host, self._port, timeout=MASTER_CALL_TIMEOUT
        )
        self._connection = None
        try:
            body = xmlrpc.client.dumps((caller,), "getPid").encode()
            connection.request("POST", self._path, body, {"Content-Type": "text/xml"})
            response = connection.getresponse()
            data = response.read()
            if response.status != 200:
                raise xmlrpc.client.ProtocolError(self._path, response.status, response.reason, {})
            (reply,), _ = xmlrpc.client.loads(data)
        except BaseException:
            connection.close()
            raise
        if response.will_close:
            connection.close()
        else:
            self._connection = connection
        return int(answer(reply, "give its pid"))

    def wait_closed(self, timeout: float, wake: int = -1) -> bool:
        """Wait up to ``timeout`` seconds for the master to close the line; True when it did.
        ``wake``: a file descriptor whose turning readable ends the wait early (False)."""
        sock = self._connection.sock if self._connection is not None else None
        waits: list[Any] = [wake] if wake >= 0 else []
        if sock is None:  # a master that closes each connection: only the slow look is left
            if waits:
                select.select(waits, [], [], timeout)
            else:
                time.sleep(timeout)
            return False
        try:
            readable, _, _ = select.select([sock, *waits], [], [], timeout)
        except (OSError, ValueError):
            readable = [sock]
        if sock in readable:
            self.close()
            return True
        return False

    def close(self) -> None:
        if self._connection is not None:
            self._connection.close()
            self._connection = None


WATCH = MasterWatch()
"""The one watch of this process (rospy allows one node per process)."""
