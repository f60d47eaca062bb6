"""The ROS 1 transport: the same interface over rospy and actionlib.

Each process is one ROS node (rospy allows no more); the components it hosts
are logical nodes sharing it, so their messages carry the process's node name
as sender (from the connection header's caller id), as in the thesis where the
controller, emotion system and motivator form the one node ``cyborg_controller``.

rospy calls back on its own threads; every callback is handed to the clock's
event loop with ``call_soon_threadsafe``, so components still run one callback
at a time. Messages are converted field by field between our dataclasses and
the generated ROS classes (the names are the same by design).

A restart of the ROS master is lived through: see :class:`_MasterWatch`.

This is the only module that imports rospy.
"""

from __future__ import annotations

import asyncio
import copy
import dataclasses
import http.client
import importlib
import inspect
import logging
import threading
import time
import weakref
import xmlrpc.client
from collections import deque
from collections.abc import Awaitable, Callable
from typing import Any, Generic

import actionlib  # type: ignore[import-not-found]
import genpy  # type: ignore[import-not-found]
import rosgraph  # type: ignore[import-not-found]
import rospy  # type: ignore[import-not-found]

from cyborg.errors import ServiceTimeoutError, ServiceUnavailableError, TransportError
from cyborg.transport.base import (
    DEFAULT_QUEUE_SIZE,
    ActionClient,
    ActionServer,
    ClientGoalHandle,
    F,
    G,
    GoalStatus,
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
from cyborg.transport.messages import ActionType, Message, ServiceType

log = logging.getLogger(__name__)


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


_ask_for_tcp_nodelay()


# --- the master going away and coming back ----------------------------------------------

MASTER_CHECK_PERIOD = 0.5  # seconds between two looks at the master, in each process
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


def _master_proxy(uri: str | None = None) -> xmlrpc.client.ServerProxy:
    """A proxy of the master for one thread, whose calls give up after MASTER_CALL_TIMEOUT."""
    return xmlrpc.client.ServerProxy(
        uri or rosgraph.get_master_uri(), transport=_TimeoutTransport(MASTER_CALL_TIMEOUT)
    )


def _value(answer: Any, what: str) -> Any:
    code, message, value = answer
    if code != 1:
        log.error("the ROS master refused to %s: %s", what, message)
    return value


class _MasterWatch:
    """Keeps this process's registrations on the ROS master through an outage or a restart of it.

    (The master going away and coming back are logged with rospy's logwarn: on the node's console,
    where rospy's own warnings go, and in its ROS log.)

    rospy tells the master of each publisher, subscriber and service once, when it is made, so a
    restarted master knows none of them (``rosnode list`` shows only /rosout) and no node that
    starts or subscribes afterwards finds them. Connections already made go on working (they do
    not pass through the master). This thread asks the master for its pid every
    MASTER_CHECK_PERIOD seconds. When it does not answer, that is logged once; when it answers
    again (with a new pid after a restart), or after a registration or a parameter could not be
    sent meanwhile, everything rospy holds is registered again as rospy's own first registration
    does (publishers, subscribers and services; actions are topics), the parameters this process
    set are set again and the ones it follows are subscribed again. Registering again with the
    same master changes nothing. While the master is away, making a publisher, subscriber or
    service does not wait for it (see :func:`_register_once`): it is registered here when it is back.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._wanted: dict[str, Any] = {}  # parameter -> the value this process set last
        self._followed: set[str] = set()  # parameters whose changes this process is told of
        self._out_of_sync = threading.Event()
        self._transports: weakref.WeakSet[RosTransport] = weakref.WeakSet()
        self._thread: threading.Thread | None = None
        self._pid: int | None = None
        self.away = False
        self.comebacks = 0

    def start(self, transport: RosTransport) -> None:
        self._transports.add(transport)
        if self._thread is not None:
            return
        try:
            self._pid = int(_value(_master_proxy().getPid(rospy.get_name()), "give its pid"))
        except UNREACHABLE:
            self._out_of_sync.set()
        self._thread = threading.Thread(target=self._run, name="ROS master watch", daemon=True)
        self._thread.start()

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
        proxy = _master_proxy()
        while True:
            time.sleep(MASTER_CHECK_PERIOD)
            if rospy.core.is_shutdown():
                return
            try:
                self._check(proxy)
            except Exception:  # the watch must outlive any surprise
                log.exception(
                    "looking at the ROS master failed; looking again in %.1f s", MASTER_CHECK_PERIOD
                )

    def _check(self, proxy: xmlrpc.client.ServerProxy) -> None:
        uri = rosgraph.get_master_uri()
        try:
            pid = int(_value(proxy.getPid(rospy.get_name()), "give its pid"))
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
            counts = self._register_all(proxy)
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
        from rospy.impl.registration import (  # type: ignore[import-not-found]
            RegManager,
            get_registration_listeners,
            get_service_manager,
            get_topic_manager,
        )

        caller, node_uri = rospy.get_name(), rospy.core.get_node_uri()
        topics, services = get_topic_manager(), get_service_manager()
        manager = next((x for x in get_registration_listeners().listeners if isinstance(x, RegManager)), None)
        with topics.lock, services.lock:  # as rospy's first registration: nothing added meanwhile
            publications, subscriptions = topics.get_publications(), topics.get_subscriptions()
            offered = services.get_services()
            for name, data_type in publications:
                _value(proxy.registerPublisher(caller, name, data_type, node_uri), f"register {name}")
            for name, data_type in subscriptions:
                publishers = _value(
                    proxy.registerSubscriber(caller, name, data_type, node_uri), f"register {name}"
                )
                if manager is not None and publishers:
                    manager.publisher_update(name, publishers)  # connects to any not connected yet
            for name, service_uri in offered:
                _value(proxy.registerService(caller, name, service_uri, node_uri), f"register {name}")
        for transport in list(self._transports):
            transport._forget_param_values()  # what the master held: a new one holds nothing
        with self._lock:
            wanted, followed = copy.deepcopy(self._wanted), set(self._followed)
        for key, value in wanted.items():
            _value(proxy.setParam(caller, key, value), f"set {key}")
        cache = rospy.impl.paramserver.get_param_server_cache()
        for key in followed:
            value = _value(proxy.subscribeParam(caller, node_uri, key), f"subscribe to {key}")
            cache.set(key, value)
        return len(publications), len(subscriptions), len(offered), len(wanted)


_WATCH = _MasterWatch()


def _register_once() -> None:
    """Make rospy register a new publisher, subscriber or service without waiting for the master.

    rospy's ``RegManager.reg_added`` calls the master again every 0.2 s until it answers, on the
    thread that made the publisher (in our nodes the event loop: a controller entering a state
    during an outage would stop there) and under rospy's topic lock. This one calls it once; if the
    master does not answer, :class:`_MasterWatch` registers it with everything else when it is back.
    (In a process without a RosTransport, where no watch runs, rospy's own way is kept.)
    """
    from rospy.impl.registration import Registration, RegManager  # type: ignore[import-not-found]

    original = RegManager.reg_added
    if getattr(original, "_cyborg_once", False):
        return

    def reg_added(self: Any, resolved_name: str, data_type_or_uri: str, reg_type: str) -> None:
        if not self.master_uri or not _WATCH.running:  # (plain rospy use: nobody would register it later)
            original(self, resolved_name, data_type_or_uri, reg_type)
            return
        proxy = _master_proxy(self.master_uri)
        args = (rospy.names.get_caller_id(), resolved_name, data_type_or_uri, self.uri)
        try:
            if reg_type == Registration.PUB:
                _value(proxy.registerPublisher(*args), f"register publisher {resolved_name}")
            elif reg_type == Registration.SUB:
                publishers = _value(proxy.registerSubscriber(*args), f"register subscriber {resolved_name}")
                if publishers:
                    self.publisher_update(resolved_name, publishers)
            elif reg_type == Registration.SRV:
                _value(proxy.registerService(*args), f"register service {resolved_name}")
        except UNREACHABLE as exc:
            _WATCH.missed(f"register {resolved_name}", exc)

    reg_added._cyborg_once = True  # type: ignore[attr-defined]
    RegManager.reg_added = reg_added


_register_once()


def listed_subscribers(topic: str) -> list[str]:
    """The nodes the master lists as subscribers of ``topic`` (empty if it does not answer)."""
    try:
        _, subscribers, _ = rosgraph.Master(rospy.get_name()).getSystemState()
    except Exception:
        return []
    return [normalize_node_name(n) for name, nodes in subscribers if name == topic for n in nodes]


_UNKNOWN = object()
FRESH_PUBLISHER_WAIT = 1.0  # seconds a new publisher's messages may wait for known subscribers
SERVER_SILENCE_LIMIT = 1.0  # seconds without a status message before an action server counts as gone
WATCHDOG_PERIOD = 0.2


# --- message conversion ---------------------------------------------------------------


def ros_class(ros_type: str, kind: str = "msg") -> Any:
    """The generated ROS class for ``pkg/Name`` (``kind`` msg or srv)."""
    package, _, name = ros_type.partition("/")
    try:
        return getattr(importlib.import_module(f"{package}.{kind}"), name)
    except (ImportError, AttributeError) as exc:
        raise TransportError(
            f"ROS type {ros_type} is not importable ({exc}); fix: source .venv/bin/activate after "
            "scripts/install-ros, which generates this project's messages"
        ) from exc


def to_ros(message: Message, cls: Any) -> Any:
    out = cls()
    for field in dataclasses.fields(message):
        value = getattr(message, field.name)
        if not hasattr(out, field.name):
            continue
        current = getattr(out, field.name)
        if isinstance(value, Message):
            setattr(out, field.name, to_ros(value, type(current)))
        elif isinstance(current, genpy.Time):
            setattr(out, field.name, rospy.Time.from_sec(max(0.0, float(value))))
        else:
            setattr(out, field.name, value)
    return out


def from_ros(ros_message: Any, cls: type[M]) -> M:
    values: dict[str, Any] = {}
    for field in dataclasses.fields(cls):
        if not hasattr(ros_message, field.name):
            continue
        value = getattr(ros_message, field.name)
        default = field.default_factory() if field.default_factory is not dataclasses.MISSING else None
        if isinstance(default, Message):
            values[field.name] = from_ros(value, type(default))
        elif hasattr(value, "to_sec"):
            values[field.name] = value.to_sec()
        elif isinstance(value, tuple):
            values[field.name] = list(value)
        else:
            values[field.name] = value
    return cls(**values)


def _check_topic_type(topic: str, msg_type: type[Message]) -> None:
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


def _caller(ros_message: Any) -> str:
    header = getattr(ros_message, "_connection_header", None) or {}
    return normalize_node_name(str(header.get("callerid", "")))


# --- transport and node ------------------------------------------------------------------


class RosTransport(Transport):
    """Nodes of this process on a running ROS master (``ROS_MASTER_URI``)."""

    def __init__(self, clock: Clock, *, process_name: str | None = None) -> None:
        self.clock = clock
        self.process_name = process_name
        self.callback_errors = 0
        self._nodes: dict[str, RosNode] = {}
        self._tasks: set[asyncio.Future[Any]] = set()
        self._watched_params: set[str] = set()
        self._param_values: dict[str, Any] = {}
        self._params_lock = threading.Lock()
        self._chained_notifier: Callable[[str, Any], None] | None = None

    def _ensure_init(self, first: str) -> None:
        if not rospy.core.is_initialized():
            rospy.init_node(self.process_name or first, anonymous=False, disable_signals=True)
        _WATCH.start(self)

    @property
    def ros_name(self) -> str:
        return normalize_node_name(rospy.get_name())

    def node(self, name: str) -> RosNode:
        name = normalize_node_name(name)
        if not name:
            raise TransportError("node name is empty: give every component a name, e.g. 'cyborg_idle'")
        if name in self._nodes:
            raise TransportError(f"node name {name!r} is already in use in this process")
        self._ensure_init(name)
        node = RosNode(self, name)
        self._nodes[name] = node
        return node

    def shutdown(self) -> None:
        for node in list(self._nodes.values()):
            node.shutdown()
        self._nodes.clear()

    def close(self, reason: str = "cyborg node stopped") -> None:
        """Shut down every node of this process and leave the graph (rospy cannot rejoin it)."""
        self.shutdown()
        rospy.signal_shutdown(reason)

    def subscribers_of(self, topic: str) -> list[str]:
        """The nodes the master lists as subscribers of ``topic`` (empty if it does not answer)."""
        return listed_subscribers(topic)

    def _forget_node(self, node: RosNode) -> None:
        if self._nodes.get(node.name) is node:
            del self._nodes[node.name]

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
        _WATCH.want(key, value)  # first: our own set's update notice must find it ours
        with self._params_lock:
            known = self._param_values.get(key, _UNKNOWN)
        if known is not _UNKNOWN and known == value:
            return
        try:
            rospy.set_param(key, copy.deepcopy(value))  # rospy's cache keeps what it is given
            if key not in self._watched_params:
                self._watched_params.add(key)
                _WATCH.follow(key)
                cache = rospy.impl.paramserver.get_param_server_cache()
                if cache.notifier != self._on_param_update:
                    self._chained_notifier = cache.notifier
                    cache.set_notifier(self._on_param_update)
                # Subscribes. An empty dict reads as "unset" in rospy's cache: hence the default.
                rospy.get_param_cached(key, None)
        except UNREACHABLE as exc:
            _WATCH.missed(f"set {key}", exc)
            return
        with self._params_lock:
            self._param_values[key] = copy.deepcopy(value)

    def _forget_param_values(self) -> None:  # the master watch's thread: a new master holds nothing
        with self._params_lock:
            self._param_values.clear()

    def _on_param_update(self, key: str, value: Any) -> None:  # rospy thread, under the cache's lock
        """A subscribed parameter changed (our own set comes here first, then records its value)."""
        changed = key.rstrip("/") + "/"
        with self._params_lock:
            for watched in list(self._param_values):
                if changed.startswith(watched + "/") or (watched + "/").startswith(changed):
                    del self._param_values[watched]
        _WATCH.changed_elsewhere(key, value)
        if self._chained_notifier is not None:
            self._chained_notifier(key, value)

    # callbacks from rospy threads run on the loop
    def to_loop(self, callback: Callable[..., object], *args: Any) -> None:
        loop = self.clock.loop
        if not loop.is_closed():
            loop.call_soon_threadsafe(self._run_callback, callback, *args)

    def _run_callback(self, callback: Callable[..., object], *args: Any) -> None:
        try:
            result = callback(*args)
            if inspect.isawaitable(result):
                self._tasks.add(task := asyncio.ensure_future(result))
                task.add_done_callback(self._tasks.discard)
        except Exception:
            self.callback_errors += 1
            log.exception(
                "callback %s failed; the transport carries on", getattr(callback, "__qualname__", callback)
            )


class RosNode(Node):
    def __init__(self, transport: RosTransport, name: str) -> None:
        self.transport = transport
        self.name = name
        self.clock = transport.clock
        self._closers: list[Callable[[], None]] = []

    def publisher(
        self, topic: str, msg_type: type[M], *, queue_size: int = DEFAULT_QUEUE_SIZE, latch: bool = False
    ) -> Publisher[M]:
        _check_topic_type(self.resolve(topic), msg_type)
        pub = _RosPublisher[M](self.resolve(topic), msg_type, queue_size, latch)
        self._closers.append(pub.unregister)
        return pub

    def subscribe(
        self,
        topic: str,
        msg_type: type[M],
        callback: Callable[[M, MessageInfo], None],
        *,
        queue_size: int = DEFAULT_QUEUE_SIZE,
    ) -> Subscription[M]:
        _check_topic_type(self.resolve(topic), msg_type)
        sub = _RosSubscription(self.transport, self.resolve(topic), msg_type, callback, queue_size)
        self._closers.append(sub.unsubscribe)
        return sub

    def advertise_service(
        self,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
    ) -> ServiceServer:
        server = _RosServiceServer(self.transport, self.resolve(name), srv_type, handler)
        self._closers.append(server.shutdown)
        return server

    def service_proxy(self, name: str, srv_type: ServiceType[Req, Resp]) -> ServiceProxy[Req, Resp]:
        return _RosServiceProxy(self.transport, self.resolve(name), srv_type)

    def action_server(
        self,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], None],
    ) -> ActionServer[G, R, F]:
        server = _RosActionServer(self.transport, self.resolve(name), action_type, on_goal, on_cancel)
        self._closers.append(server.shutdown)
        return server

    def action_client(self, name: str, action_type: ActionType[G, R, F]) -> ActionClient[G, R, F]:
        client = _RosActionClient(self.transport, self.resolve(name), action_type)
        self._closers.append(client.close)
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

    def shutdown(self) -> None:
        for close in reversed(self._closers):
            try:
                close()
            except Exception:
                log.debug("closing failed", exc_info=True)
        self._closers.clear()
        self.transport._forget_node(self)  # the name is free again, as on the embedded transport


# --- topics -----------------------------------------------------------------------------


class _RosPublisher(Publisher[M]):
    """A rospy publisher whose first messages wait for the subscribers the master already knows.

    A subscriber connects to a new publisher only after the master told it about it (Python's
    rosmaster hands such notices to workers that look for work every 0.1 s), so rospy drops what
    a publisher made on the spot sends at once (a module's first sentence). For
    FRESH_PUBLISHER_WAIT seconds after it is made, a message sent while fewer subscribers are
    connected than the master lists waits, on a thread, until they are (or that time is up);
    later messages queue behind it, so the order holds.
    """

    def __init__(self, topic: str, msg_type: type[M], queue_size: int, latch: bool) -> None:
        self.topic = topic
        self._cls = ros_class(msg_type.ros_type)
        self._pub = rospy.Publisher(topic, self._cls, queue_size=queue_size, latch=latch)
        self._fresh_until = time.monotonic() + FRESH_PUBLISHER_WAIT
        self._expected: int | None = None
        self._pending: deque[Any] | None = None
        self._lock = threading.Lock()

    def publish(self, message: M) -> None:
        ros_message = to_ros(message, self._cls)
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
        return int(self._pub.get_num_connections())

    def unregister(self) -> None:
        self._pub.unregister()


class _RosSubscription(Subscription[M]):
    def __init__(
        self,
        transport: RosTransport,
        topic: str,
        msg_type: type[M],
        callback: Callable[[M, MessageInfo], None],
        queue_size: int,
    ) -> None:
        self.topic = topic
        self._transport = transport
        self._type = msg_type
        self._callback = callback
        self._queue: deque[tuple[M, MessageInfo]] = deque()
        self._queue_size = queue_size
        self._dropped = 0
        self._scheduled = False
        self._sub = rospy.Subscriber(topic, ros_class(msg_type.ros_type), self._on_ros, queue_size=None)

    @property
    def dropped(self) -> int:
        return self._dropped

    def _on_ros(self, ros_message: Any) -> None:  # rospy thread
        info = MessageInfo(sender=_caller(ros_message), stamp=time.time())
        message = from_ros(ros_message, self._type)
        self._transport.to_loop(self._enqueue, message, info)

    def _enqueue(self, message: M, info: MessageInfo) -> None:
        if len(self._queue) >= self._queue_size:
            self._queue.popleft()
            self._dropped += 1
        self._queue.append((message, info))
        if not self._scheduled:
            self._scheduled = True
            self._transport.clock.loop.call_soon(self._drain)

    def _drain(self) -> None:
        self._scheduled = False
        while self._queue:
            message, info = self._queue.popleft()
            self._transport._run_callback(self._callback, message, info)

    def unsubscribe(self) -> None:
        self._sub.unregister()
        self._queue.clear()


# --- services ---------------------------------------------------------------------------


class _RosServiceServer(ServiceServer, Generic[Req, Resp]):
    def __init__(
        self,
        transport: RosTransport,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
    ) -> None:
        self.name = name
        self._transport = transport
        self._srv_type = srv_type
        self._handler = handler
        self._srv_cls = ros_class(srv_type.ros_type, "srv")
        self._service = rospy.Service(name, self._srv_cls, self._on_request)

    def _on_request(self, ros_request: Any) -> Any:  # rospy thread
        request = from_ros(ros_request, self._srv_type.request)
        info = MessageInfo(sender=_caller(ros_request), stamp=time.time())

        async def answer() -> Resp:
            result = self._handler(request, info)
            if inspect.isawaitable(result):
                result = await result
            return result  # type: ignore[return-value]

        future = asyncio.run_coroutine_threadsafe(answer(), self._transport.clock.loop)
        response = future.result(timeout=60.0)
        return to_ros(response, self._srv_cls._response_class)

    def shutdown(self) -> None:
        self._service.shutdown("node shutting down")


class _RosServiceProxy(ServiceProxy[Req, Resp]):
    def __init__(self, transport: RosTransport, name: str, srv_type: ServiceType[Req, Resp]) -> None:
        self.name = name
        self._transport = transport
        self._srv_type = srv_type
        self._srv_cls = ros_class(srv_type.ros_type, "srv")
        self._proxy = rospy.ServiceProxy(name, self._srv_cls)

    def available(self) -> bool:
        try:
            rospy.wait_for_service(self.name, timeout=0.05)
        except rospy.ROSException:
            return False
        return True

    async def wait_for_service(self, timeout: float) -> bool:
        loop = asyncio.get_running_loop()
        try:
            await loop.run_in_executor(
                None, lambda: rospy.wait_for_service(self.name, timeout=max(timeout, 0.01))
            )
        except rospy.ROSException:
            return False
        return True

    async def call(self, request: Req | None = None, *, timeout: float = 5.0) -> Resp:
        loop = asyncio.get_running_loop()
        req = request if request is not None else self._srv_type.request()
        if not await loop.run_in_executor(None, self.available):
            raise ServiceUnavailableError(
                f"service {self.name} is not offered by any node: start the component that offers it"
            )
        ros_request = to_ros(req, self._srv_cls._request_class)
        try:
            ros_response = await asyncio.wait_for(
                loop.run_in_executor(None, self._proxy.call, ros_request), timeout
            )
        except TimeoutError as exc:
            raise ServiceTimeoutError(
                f"service {self.name} gave no answer within {timeout} s: check that its node is running "
                "and not blocked, or raise the timeout"
            ) from exc
        except rospy.ServiceException as exc:
            raise TransportError(f"service {self.name} failed: {exc}") from exc
        return from_ros(ros_response, self._srv_type.response)


# --- actions ----------------------------------------------------------------------------


def _action_classes(action_type: ActionType[Any, Any, Any]) -> Any:
    return ros_class(action_type.ros_type)


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


class _RosServerGoalHandle(ServerGoalHandle[G, R, F]):
    def __init__(self, server: _RosActionServer[G, R, F], ros_handle: Any) -> None:
        self._server = server
        self._handle = ros_handle
        goal_id = ros_handle.get_goal_id()
        self.goal_id = str(goal_id.id)
        self.goal = from_ros(ros_handle.get_goal(), server.action_type.goal)
        self.sender = _caller(ros_handle.get_goal()) or str(goal_id.id).split("-", 1)[0].lstrip("/")

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
        try:
            method(*args)
        except Exception:
            log.warning(
                "action %s: %s failed in status %s", self._server.name, method.__name__, self.status.name
            )
        if self.status.is_terminal:
            self._server.forget(self.goal_id)


class _RosActionServer(ActionServer[G, R, F]):
    def __init__(
        self,
        transport: RosTransport,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], None],
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
        self._server = actionlib.ActionServer(
            name, _action_classes(action_type), self._goal_cb, self._cancel_cb, auto_start=False
        )
        self._server.start()

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
        self._transport.to_loop(self._on_goal, self._wrap(ros_handle))

    def _cancel_cb(self, ros_handle: Any) -> None:  # rospy thread
        self._transport.to_loop(self._on_cancel, self._wrap(ros_handle))

    def shutdown(self) -> None:
        for attribute in ("status_pub", "result_pub", "feedback_pub"):
            publisher = getattr(self._server, attribute, None)
            if publisher is not None:
                publisher.unregister()
        for attribute in ("goal_sub", "cancel_sub"):
            subscriber = getattr(self._server, attribute, None)
            if subscriber is not None:
                subscriber.unregister()
        timer = getattr(self._server, "status_timer", None)
        if timer is not None:
            timer.shutdown()


class _WatchedActionClient(actionlib.ActionClient):  # type: ignore[misc]
    """actionlib's client, remembering when the server last reported its status."""

    last_status_time = 0.0

    def _status_cb(self, msg: Any) -> None:
        self.last_status_time = time.monotonic()
        super()._status_cb(msg)


class _RosClientGoalHandle(ClientGoalHandle[G, R, F]):
    def __init__(self, client: _RosActionClient[G, R, F], goal: G, on_feedback: Any, on_status: Any) -> None:
        self._client = client
        self.goal = goal
        self._status = GoalStatus.PENDING
        self._result: R | None = None
        self._text = ""
        self._on_feedback = on_feedback
        self._on_status = on_status
        self._done: list[Callable[[ClientGoalHandle[G, R, F]], None]] = []
        self._waiters: list[asyncio.Future[GoalStatus]] = []
        self._ros: Any = None

    @property
    def status(self) -> GoalStatus:
        return self._status

    @property
    def result(self) -> R | None:
        return self._result

    @property
    def text(self) -> str:
        return self._text

    def cancel(self) -> None:
        if self._ros is not None and not self._status.is_terminal:
            self._ros.cancel()

    async def wait(self) -> GoalStatus:
        if self._status.is_terminal:
            return self._status
        future: asyncio.Future[GoalStatus] = self._client.transport.clock.loop.create_future()
        self._waiters.append(future)
        return await future

    def add_done_callback(self, callback: Callable[[ClientGoalHandle[G, R, F]], None]) -> None:
        if self._status.is_terminal:
            self._client.transport.clock.loop.call_soon(callback, self)
        else:
            self._done.append(callback)

    # on the loop
    def _update(self, status: GoalStatus, result: R | None, text: str) -> None:
        if self._status.is_terminal or status is self._status:
            return
        self._status = status
        transport = self._client.transport
        if self._on_status is not None:
            transport._run_callback(self._on_status, status)
        if status.is_terminal:
            self._result, self._text = result, text
            self._client.forget(self)
            for waiter in self._waiters:
                if not waiter.done():
                    waiter.set_result(status)
            self._waiters.clear()
            callbacks, self._done = self._done, []
            for callback in callbacks:
                transport._run_callback(callback, self)

    def _feedback(self, feedback: F) -> None:
        if self._on_feedback is not None and not self._status.is_terminal:
            self._client.transport._run_callback(self._on_feedback, feedback)


class _RosActionClient(ActionClient[G, R, F]):
    def __init__(self, transport: RosTransport, name: str, action_type: ActionType[G, R, F]) -> None:
        self.name = name
        self.transport = transport
        self.action_type = action_type
        self._goal_cls = ros_class(action_type.goal.ros_type)
        self._order = goal_order(self._goal_cls, action_type.goal)  # the public package's 'order'
        self._classes = _action_classes(action_type)
        self._client: Any = None
        self._active: set[_RosClientGoalHandle[G, R, F]] = set()
        self._watchdog: asyncio.TimerHandle | None = None
        self._make_client()

    def _make_client(self) -> bool:
        """Make actionlib's client, unless made already. actionlib asks the master for parameters
        while it makes one: while the master is away it cannot, and what it made so far is undone;
        the client is made at a later look for the server (``server_available``)."""
        if self._client is not None:
            return True
        client = _WatchedActionClient.__new__(_WatchedActionClient)
        try:
            actionlib.ActionClient.__init__(client, self.name, self._classes)
        except UNREACHABLE as exc:
            for part in ("pub_goal", "pub_cancel", "status_sub", "result_sub", "feedback_sub"):
                if (made := getattr(client, part, None)) is not None:
                    made.unregister()
            _WATCH.missed(f"make the action client {self.name}", exc)
            return False
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
        last = client.last_status_msg
        if last is None or time.monotonic() - client.last_status_time > SERVER_SILENCE_LIMIT:
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
        deadline = time.monotonic() + timeout
        while not self.server_available():
            if time.monotonic() >= deadline:
                return False
            await asyncio.sleep(0.01)
        return True

    def send_goal(
        self,
        goal: G,
        *,
        on_feedback: Callable[[F], None] | None = None,
        on_status: Callable[[GoalStatus], None] | None = None,
    ) -> ClientGoalHandle[G, R, F]:
        handle = _RosClientGoalHandle(self, goal, on_feedback, on_status)
        transport = self.transport

        def transition(ros_handle: Any) -> None:  # rospy thread
            status = GoalStatus(int(ros_handle.get_goal_status()))
            result = None
            text = ""
            if ros_handle.get_comm_state() == actionlib.CommState.DONE:
                raw = ros_handle.get_result()
                result = (
                    from_ros(raw, self.action_type.result) if raw is not None else self.action_type.result()
                )
                text = str(ros_handle.get_goal_status_text())
            elif status.is_terminal:
                return  # wait for DONE to carry the result
            transport.to_loop(handle._update, status, result, text)

        def feedback(ros_handle: Any, ros_feedback: Any) -> None:  # rospy thread
            transport.to_loop(handle._feedback, from_ros(ros_feedback, self.action_type.feedback))

        if not self.server_available():
            transport.clock.loop.call_soon(
                handle._update, GoalStatus.LOST, None, f"no action server at {self.name}"
            )
            return handle
        ros_goal = to_ros(goal, self._goal_cls)
        if self._order is not None:
            setattr(ros_goal, ORDER_FIELD, self._order)
        handle._ros = self._client.send_goal(ros_goal, transition, feedback)
        self._active.add(handle)
        self._arm_watchdog()
        return handle

    def forget(self, handle: _RosClientGoalHandle[G, R, F]) -> None:
        self._active.discard(handle)

    def _arm_watchdog(self) -> None:
        if self._watchdog is None:
            self._watchdog = self.transport.clock.loop.call_later(WATCHDOG_PERIOD, self._check_server)

    def _check_server(self) -> None:
        """Goals of a vanished server end LOST (actionlib alone would wait forever)."""
        self._watchdog = None
        if not self._active:
            return
        if not self.server_available():
            for handle in list(self._active):
                handle._update(GoalStatus.LOST, None, "action server gone")
            return
        self._arm_watchdog()

    def close(self) -> None:
        if self._watchdog is not None:
            self._watchdog.cancel()
        if self._client is not None:
            self._client.stop()
