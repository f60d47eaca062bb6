"""The ROS 2 transport's entry point: :class:`Ros2Transport`, its nodes and parameters.

Part of :mod:`cyborg.transport.ros2`. A Ros2Transport is one rclpy context (``ROS_DOMAIN_ID``
and ``ROS_AUTOMATIC_DISCOVERY_RANGE`` from the environment) whose nodes are spun by one
multi-threaded executor on a thread of its own. Unlike rospy, rclpy allows many nodes per
process, so every logical node is a real ROS 2 node: a message's sender is the node that
published it, as on the embedded transport. Callbacks arrive on the executor's threads and run
on the clock's event loop (:meth:`Ros2Transport.to_loop`), one at a time.

Parameters: ROS 2 has no parameter server. Our absolute parameters (``/state_resources``,
``/cyborg_controller/transitions``, ...) live as ROS 2 parameters of one node, the parameter
home ``/cyborg_parameters`` (names without the leading slash, ``/`` as ``.``; values as JSON
strings, since a ROS 2 parameter cannot hold a dict). The first process that sets a parameter
hosts it, unless the graph already has it; every other process reads and writes it through
its standard parameter services (``get_parameters``, ``set_parameters``), waiting for the
answer, as a rospy parameter call waits for the master. So the controller's ``set_param``
of the active state's resources returns only once the home holds them, before the state
change is published; a gatekeeper reads them when the state change arrives; a read that
fails raises TransportError, and the gatekeeper passes nothing (fails closed). A read where no
home is on the graph waits for one as long as a call waits for its answer, then gives the
default.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import tempfile
import threading
import time
from collections.abc import Awaitable, Callable, Iterator
from pathlib import Path
from typing import Any

import rclpy
from rcl_interfaces.msg import Parameter as RosParameter
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.context import Context
from rclpy.node import Node as RclNode
from rclpy.parameter import Parameter as RclParameter
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
from rclpy.time import Time as RclTime

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
)
from cyborg.transport.clock import Clock
from cyborg.transport.graph import GraphNode, GraphView
from cyborg.transport.lockstep import LockstepClock
from cyborg.transport.messages import ActionType, ServiceType
from cyborg.transport.ros2.actions import Ros2ActionClient, Ros2ActionServer
from cyborg.transport.ros2.convert import ros2_class, ros2_type_name
from cyborg.transport.ros2.executor import HandOffExecutor
from cyborg.transport.ros2.services import Ros2ServiceProxy, Ros2ServiceServer
from cyborg.transport.ros2.topics import Ros2Publisher, Ros2Subscription

__all__ = ["PARAM_HOME", "PARAM_TIMEOUT", "Ros2Node", "Ros2Transport", "parameter_name"]

log = logging.getLogger(__name__)

PARAM_HOME = "cyborg_parameters"
PARAM_TIMEOUT = 2.0  # seconds a parameter read or write waits for the home's answer
LOCKSTEP_PARAM_TIMEOUT = 10.0  # the same in lockstep time, which stands still meanwhile
EXECUTOR_THREADS = 32  # an action goal being executed holds one thread while it runs
NODE_GONE_WAIT = 1.0  # seconds a node's shutdown waits until the graph has lost it
CONNECT_POLL_PERIOD = 0.05  # seconds between two looks at the graph in wait_for_connections
_RCL_OWN_TOPICS = frozenset({"/rosout", "/parameter_events"})


PARTICIPANT_LEASE = 1.0  # seconds after a process's last sign of life until the others drop it
LEASE_ANNOUNCEMENT = 0.25  # seconds between a process's signs of life
PROFILE_VARIABLES = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")
_PROFILE = f"""<?xml version="1.0" encoding="UTF-8" ?>
<dds xmlns="http://www.eprosima.com">
  <profiles>
    <participant profile_name="cyborg_participant" is_default_profile="true">
      <rtps><builtin><discovery_config>
        <leaseDuration><sec>{int(PARTICIPANT_LEASE)}</sec>
          <nanosec>{round(PARTICIPANT_LEASE % 1 * 1e9)}</nanosec></leaseDuration>
        <leaseAnnouncement><sec>{int(LEASE_ANNOUNCEMENT)}</sec>
          <nanosec>{round(LEASE_ANNOUNCEMENT % 1 * 1e9)}</nanosec></leaseAnnouncement>
      </discovery_config></builtin></rtps>
    </participant>
  </profiles>
</dds>
"""


@contextlib.contextmanager
def _participant_profile() -> Iterator[None]:
    """Fast DDS's participant, made while this is active, announces itself every
    LEASE_ANNOUNCEMENT s and is dropped by every other process PARTICIPANT_LEASE s after its
    last announcement (Fast DDS's default: 20 s). So a module process that is killed
    mid-goal is gone from the controller's graph within about a second, and its goal ends
    LOST (the controller takes 'aborted'), as under ROS 1, where its TCP connections close.
    Fast DDS reads the profile from the environment when rclpy.init makes the participant; a
    profile the user set (FASTDDS_DEFAULT_PROFILES_FILE) is left alone, and the environment is
    restored afterwards, so processes started from this one keep Fast DDS's defaults."""
    if any(os.environ.get(name) for name in PROFILE_VARIABLES):
        yield
        return
    with tempfile.TemporaryDirectory(prefix="cyborg-fastdds-") as folder:
        path = Path(folder) / "participant.xml"
        path.write_text(_PROFILE)
        os.environ[PROFILE_VARIABLES[0]] = str(path)
        try:
            yield
        finally:
            del os.environ[PROFILE_VARIABLES[0]]


def parameter_name(key: str) -> str:
    """The home's ROS 2 parameter for our absolute ``key``: ``/a/b`` -> ``a.b``."""
    return key.strip("/").replace("/", ".")


def _fits(publisher_qos: Any, subscription_qos: Any) -> bool:
    """Whether DDS matches a publisher and a subscription of these QoS profiles, by the policies
    our endpoints set: a volatile publisher never matches a transient-local subscription (each of
    ours has such a half) nor a best-effort one a reliable subscription. (rclpy's
    qos_check_compatible would also compare deadlines and leases, which the graph reports in
    another form than the endpoint's own default.)"""
    volatile_to_latched = (
        publisher_qos.durability == DurabilityPolicy.VOLATILE
        and subscription_qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
    )
    best_effort_to_reliable = (
        publisher_qos.reliability == ReliabilityPolicy.BEST_EFFORT
        and subscription_qos.reliability == ReliabilityPolicy.RELIABLE
    )
    return not (volatile_to_latched or best_effort_to_reliable)


_DESTROYED_ENTITY = ("pointer is invalid", "destruction was requested")
"""What rclpy raises while it builds its wait set as one of the entities is destroyed."""


class Ros2Transport(Transport):
    """Nodes of this process on a ROS 2 graph (one rclpy context, spun on its own thread)."""

    def __init__(self, clock: Clock, *, args: list[str] | None = None, use_sim_time: bool = False) -> None:
        """``use_sim_time``: every rclpy node follows ``/clock`` (its parameter ``use_sim_time``), so
        what rclpy stamps and times runs in the simulated time our clock publishes there."""
        super().__init__(clock)
        self.use_sim_time = use_sim_time
        self.context = Context()
        with _participant_profile():  # Fast DDS makes its participant with this process's first node
            rclpy.init(args=args, context=self.context)
            self._probe: RclNode | None = RclNode(
                f"_cyborg_graph_{os.getpid()}_{id(self):x}", context=self.context
            )
        self.executor = HandOffExecutor(EXECUTOR_THREADS, context=self.context)
        self._types: dict[str, str] = {}  # topic -> our ROS type, of this process's endpoints
        self._home: RclNode | None = None
        self._params: dict[str, Any] = {}
        self._params_lock = threading.Lock()
        self._param_node: RclNode | None = None
        self._param_clients: dict[str, Any] = {}
        self._lockstep_clocks: list[Any] = []  # the rclpy clocks set from lockstep time
        self._spinner = threading.Thread(target=self._spin, name="ros2 executor", daemon=True)
        self._spinner.start()

    def _spin(self) -> None:
        """Spin until the transport closes. rclpy's ``spin()`` raises what a callback on one of
        its threads raised, or what went wrong while it waited, and stops spinning: such a
        failure is logged and spinning goes on, or every node of the process would fall silent."""
        while True:
            try:
                self.executor.spin()
                return  # shut down
            except Exception as exc:
                if not self.context.ok():
                    log.debug("executor stopped", exc_info=True)
                    return
                # Also seen: rclpy building its wait set while an action client or server is
                # destroyed ("action client pointer is invalid"); the next turn goes without it.
                # Only this process destroys its entities (a node closes, or the process ends, as
                # one of the modules sharing a process stops before the others): that is
                # expected, a debug line, not a warning on the terminal.
                destroyed = any(sign in str(exc) for sign in _DESTROYED_ENTITY)
                log.log(
                    logging.DEBUG if self._closed or destroyed else logging.WARNING,
                    "the ROS 2 executor raised (%s); it spins on",
                    exc,
                    exc_info=log.isEnabledFor(logging.DEBUG),
                )

    def node(self, name: str) -> Ros2Node:
        """A logical node, one rclpy node (see :meth:`Transport.node`).

        Raises TransportError also when rclpy refuses the name.
        """
        return self._add_node(name, lambda free: Ros2Node(self, free))

    def _ros2_nodes(self) -> list[Ros2Node]:
        return [node for node in self._nodes.values() if isinstance(node, Ros2Node)]

    def make_rcl_node(self, name: str) -> RclNode:
        """A new rclpy node of this context, spun by the executor; TransportError for a bad name."""
        try:
            rcl = RclNode(
                name,
                context=self.context,
                start_parameter_services=False,
                parameter_overrides=[RclParameter("use_sim_time", value=True)] if self.use_sim_time else [],
            )
        except Exception as exc:
            raise TransportError(
                f"cannot make the ROS 2 node {name!r} ({exc}); fix: a node name has letters, digits and "
                "underscores and does not start with a digit"
            ) from exc
        if self.use_sim_time and isinstance(self.clock, LockstepClock):
            self._follow_lockstep(rcl)
        self.executor.add_node(rcl)
        return rcl

    def _follow_lockstep(self, rcl: RclNode) -> None:
        """In lockstep the node's ROS time is set from the granted time in this process: a /clock
        subscription in every node would wake every process at every step of the time."""
        source = getattr(rcl, "_time_source", None)
        subscription = getattr(source, "_clock_sub", None)
        if subscription is None:
            return  # another rclpy: it follows /clock as a foreign node does
        rcl.destroy_subscription(subscription)
        source._clock_sub = None  # type: ignore[union-attr]
        if not self._lockstep_clocks:
            assert isinstance(self.clock, LockstepClock)
            self.clock.on_advance.append(self._set_ros_time)
        self._lockstep_clocks.append(rcl.get_clock())
        self._set_ros_time()

    def _set_ros_time(self) -> None:
        now = RclTime(nanoseconds=round(self.clock.now() * 1e9))
        for clock in self._lockstep_clocks:
            clock.set_ros_time_override(now)

    def drop_rcl_node(self, rcl: RclNode) -> None:
        """Take ``rcl`` off the graph, and wait (up to NODE_GONE_WAIT s) until the graph has lost it.

        rclpy destroys a node once the executor no longer uses it, a few ms after
        ``destroy_node``. A node made with the same name before then shares the name with the
        old one in the graph, and the old one's removal takes the new one's publishers with it:
        the graph names their node _NODE_NAME_UNKNOWN_ for good, and a gatekeeper drops what
        they send (seen when a test or a restarted module makes a node of a name just freed).
        """
        with contextlib.suppress(ValueError):
            self._lockstep_clocks.remove(rcl.get_clock())
        name, namespace = rcl.get_name(), rcl.get_namespace()
        probe = self._graph_probe()
        before = self._count_nodes(probe, name, namespace)
        self.executor.remove_node(rcl)
        rcl.destroy_node()
        deadline = time.monotonic() + NODE_GONE_WAIT
        while self._count_nodes(probe, name, namespace) >= before:
            if time.monotonic() >= deadline:
                log.debug("node %s still in the graph %.1f s after it was destroyed", name, NODE_GONE_WAIT)
                return
            time.sleep(0.001)

    def _graph_probe(self) -> RclNode:
        """The hidden node of this process that reads the graph while others come and go."""
        if self._probe is None:
            raise TransportError("the ROS 2 transport is closed; fix: make a new Ros2Transport")
        return self._probe

    def graph_node_names(self) -> set[str]:
        """The names of the nodes the graph shows now in the root namespace (discovery fills it
        over time), this process's included."""
        probe = self._graph_probe()
        return {name for name, namespace in probe.get_node_names_and_namespaces() if namespace == "/"}

    def own_node_names(self) -> set[str]:
        """The names of this process's nodes, its hidden ones included."""
        hidden = [self._probe, self._home, self._param_node]
        return {rcl.get_name() for rcl in hidden if rcl is not None} | {
            node.rcl.get_name() for node in self._ros2_nodes()
        }

    @staticmethod
    def _count_nodes(probe: RclNode, name: str, namespace: str) -> int:
        return sum(1 for n, ns in probe.get_node_names_and_namespaces() if (n, ns) == (name, namespace))

    def check_topic_type(self, topic: str, ros_type: str, probe: RclNode) -> None:
        """A topic carries one type: refuse a publisher or subscriber of another (this process,
        then the graph)."""
        known = self._types.get(topic)
        if known is None:
            wanted = ros2_type_name(ros2_class(ros_type))
            for name, types in probe.get_topic_names_and_types():
                if name == topic and types and wanted not in types:
                    package, _, rest = types[0].partition("/msg/")
                    known = f"{package}/{rest}"
        if known not in (None, ros_type):
            raise TransportError(
                f"topic {topic} carries {known}, not {ros_type}: "
                "use the same message type on every publisher and subscriber of a topic"
            )
        self._types[topic] = ros_type

    def wake(self) -> None:
        """Wake the executor, so that it takes up what another thread made or finished."""
        self.executor.wake()

    def graph(self, *, ask_nodes: bool = True) -> GraphView:
        """Every node discovery shows now (this process's hidden probe left out), with what it
        publishes, subscribes and serves; actions show as their hidden ``_action`` topics and
        services. (``ask_nodes``: as ROS 1's; discovery knows only the nodes that are there.)"""
        probe = self._graph_probe()
        nodes: dict[str, GraphNode] = {}
        for name, namespace in probe.get_node_names_and_namespaces():
            if (name, namespace) == (probe.get_name(), probe.get_namespace()):
                continue
            try:
                pubs = probe.get_publisher_names_and_types_by_node(name, namespace)
                subs = probe.get_subscriber_names_and_types_by_node(name, namespace)
                srvs = probe.get_service_names_and_types_by_node(name, namespace)
            except Exception:  # gone between the two calls (rclpy raises NodeNameNonExistentError)
                continue
            full = f"{namespace.rstrip('/')}/{name}".lstrip("/")
            nodes[full] = GraphNode(
                full,
                frozenset(t for t, _ in pubs),
                frozenset(t for t, _ in subs),
                frozenset(t for t, _ in srvs),
            )
        return GraphView(nodes)

    def subscribers_of(self, topic: str) -> list[str]:
        """The nodes the graph knows as subscribers of ``topic`` (discovery may lag a moment)."""
        probe = self._param_node or next((node.rcl for node in self._ros2_nodes()), None)
        if probe is None:
            return []
        return sorted({info.node_name for info in probe.get_subscriptions_info_by_topic(topic)})

    def subscription_endpoints(self, topic: str) -> int:
        """The subscriptions (DDS readers) the graph knows on ``topic``: ours are two each."""
        probe = self._param_node or next((node.rcl for node in self._ros2_nodes()), None)
        return 0 if probe is None else len(probe.get_subscriptions_info_by_topic(topic))

    # --- parameters -------------------------------------------------------------------------

    def parameter_home_visible(self) -> bool:
        """True once this process hosts the parameter home or the graph shows it (a fresh process
        learns other nodes' names a moment after their topics and services)."""
        probe = self._param_node or next((node.rcl for node in self._ros2_nodes()), None)
        return self._home is not None or (probe is not None and self._home_elsewhere(probe))

    def _home_elsewhere(self, probe: RclNode) -> bool:
        return any(
            name == PARAM_HOME and namespace == "/"
            for name, namespace in probe.get_node_names_and_namespaces()
        )

    def set_param(self, key: str, value: Any, probe: RclNode) -> None:
        """Set ``key`` at the parameter home (here, or through its services); see the module docstring."""
        text = json.dumps(value, sort_keys=True)
        if self._home is None and not self._home_elsewhere(probe):
            self._home = RclNode(PARAM_HOME, context=self.context, allow_undeclared_parameters=True)
            self.executor.add_node(self._home)
        if self._home is not None:
            with self._params_lock:
                self._params[key] = json.loads(text)
            name = parameter_name(key)
            if self._home.has_parameter(name) and self._home.get_parameter(name).value == text:
                return  # held already (the controller sets /state_resources at every handover)
            self._home.set_parameters([RclParameter(name, value=text)])
            return
        request = SetParameters.Request()
        request.parameters = [
            RosParameter(
                name=parameter_name(key),
                value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=text),
            )
        ]
        response = self._call_home(probe, "set_parameters", SetParameters, request, f"set {key}")
        if not all(result.successful for result in response.results):
            raise TransportError(f"the parameter home refused {key}: {response.results}")

    def get_param(self, key: str, default: Any, probe: RclNode) -> Any:
        """``key``'s value at the parameter home, or ``default``; see the module docstring."""
        if self._home is not None:
            with self._params_lock:
                return self._params.get(key, default)
        if not self._home_elsewhere(probe) and not self._home_answers("get_parameters", GetParameters):
            return default
        request = GetParameters.Request()
        request.names = [parameter_name(key)]
        response = self._call_home(probe, "get_parameters", GetParameters, request, f"read {key}")
        values = list(response.values)
        if not values or values[0].type != ParameterType.PARAMETER_STRING:
            return default
        return json.loads(values[0].string_value)

    def _param_client(self, service: str, srv: Any) -> Any:
        if self._param_node is None:
            self._param_node = self.make_rcl_node(f"cyborg_parameter_client_{id(self):x}")
        client = self._param_clients.get(service)
        if client is None:
            client = self._param_clients[service] = self._param_node.create_client(
                srv, f"/{PARAM_HOME}/{service}", callback_group=ReentrantCallbackGroup()
            )
        return client

    def _param_limit(self) -> float:
        # In lockstep the time stands still while a call waits: a loaded machine may take longer.
        return LOCKSTEP_PARAM_TIMEOUT if self.clock.is_lockstep else PARAM_TIMEOUT

    def _home_answers(self, service: str, srv: Any) -> bool:
        """Whether the home's ``service`` is (or becomes, within the limit) ready. The graph's
        list of node names can lag behind its services on a loaded machine: a gatekeeper that
        heard the controller's state change once read no resources here, and passed nothing."""
        client = self._param_client(service, srv)
        return bool(client.service_is_ready() or client.wait_for_service(timeout_sec=self._param_limit()))

    def _call_home(self, probe: RclNode, service: str, srv: Any, request: Any, what: str) -> Any:
        """Call a parameter service of the home and wait for its answer (the loop waits too)."""
        client = self._param_client(service, srv)
        started = time.monotonic()
        limit = self._param_limit()
        # A client made a moment ago may not have discovered the home's service yet: a request
        # sent before that goes nowhere.
        if not client.service_is_ready():
            client.wait_for_service(timeout_sec=limit)
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        self.executor.wake()
        if not done.wait(max(0.0, limit - (time.monotonic() - started))) or future.result() is None:
            client.remove_pending_request(future)
            raise TransportError(
                f"could not {what}: the parameter home /{PARAM_HOME} did not answer within {limit:g} s; "
                "fix: start the controller's node (it hosts the parameters); if it runs, the node of "
                "that name on this graph is another robot's or a leftover: stop it, or give this robot "
                "a ROS_DOMAIN_ID of its own"
            )
        return future.result()

    def wait_for_connections(self, timeout: float) -> list[str]:
        """See :meth:`Transport.wait_for_connections`: each publisher and subscription of this
        process's nodes matched with every endpoint of a fitting QoS the graph lists on its topic
        (DDS discovery runs on its own threads; one listed but never matched is one just gone)."""
        deadline = time.monotonic() + timeout
        while True:
            missing = self._unmatched()
            if not missing or time.monotonic() >= deadline:
                return missing
            time.sleep(CONNECT_POLL_PERIOD)

    def _unmatched(self) -> list[str]:
        missing: list[str] = []
        for node in self._ros2_nodes():
            rcl = node.rcl
            for pub in [p for p in rcl.publishers if p.topic_name not in _RCL_OWN_TOPICS]:
                infos = rcl.get_subscriptions_info_by_topic(pub.topic_name)
                short = (
                    sum(_fits(pub.qos_profile, i.qos_profile) for i in infos) - pub.get_subscription_count()
                )
                if short > 0:
                    missing.append(f"{node.name} -> {short} subscriber(s) on {pub.topic_name}")
            for sub in [s for s in rcl.subscriptions if s.topic_name not in _RCL_OWN_TOPICS]:
                infos = rcl.get_publishers_info_by_topic(sub.topic_name)
                short = sum(_fits(i.qos_profile, sub.qos_profile) for i in infos) - sub.get_publisher_count()
                if short > 0:
                    missing.append(f"{short} publisher(s) -> {node.name} on {sub.topic_name}")
        return missing

    def _leave(self) -> None:
        """Leave the graph: the parameter home and the hidden nodes go, then the executor and the context."""
        for extra in (self._home, self._param_node):
            if extra is not None:
                self.drop_rcl_node(extra)
        self._home = self._param_node = None
        if self._probe is not None:
            self._probe.destroy_node()
            self._probe = None
        self.executor.shutdown(timeout_sec=1.0)
        if self.context.ok():
            self.context.try_shutdown()
        self._spinner.join(timeout=2.0)


class Ros2Node(Node):
    """One logical node: one rclpy node."""

    def __init__(self, transport: Ros2Transport, name: str) -> None:
        super().__init__(transport, name)
        self.transport = transport
        self.rcl = transport.make_rcl_node(name)
        self.on_shutdown(self._drop_rcl)  # the last to close
        self._group = ReentrantCallbackGroup()

    def publisher(
        self, topic: str, msg_type: type[M], *, queue_size: int = DEFAULT_QUEUE_SIZE, latch: bool = False
    ) -> Publisher[M]:
        resolved = self.resolve(topic)
        self.transport.check_topic_type(resolved, msg_type.ros_type, self.rcl)
        pub = Ros2Publisher[M](self.transport, self.rcl, resolved, msg_type, queue_size, latch)
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
        resolved = self.resolve(topic)
        self.transport.check_topic_type(resolved, msg_type.ros_type, self.rcl)
        sub = Ros2Subscription(
            self.transport, self.rcl, resolved, msg_type, callback, queue_size, self._group
        )
        self.on_shutdown(sub.unsubscribe)
        return sub

    def advertise_service(
        self,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
    ) -> ServiceServer:
        server = Ros2ServiceServer(
            self.transport, self.rcl, self.resolve(name), srv_type, handler, self._group
        )
        self.on_shutdown(server.shutdown)
        return server

    def service_proxy(self, name: str, srv_type: ServiceType[Req, Resp]) -> ServiceProxy[Req, Resp]:
        proxy = Ros2ServiceProxy(self.transport, self.rcl, self.resolve(name), srv_type, self._group)
        self.on_shutdown(proxy.close)
        return proxy

    def action_server(
        self,
        name: str,
        action_type: ActionType[G, R, F],
        on_goal: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
        on_cancel: Callable[[ServerGoalHandle[G, R, F]], Awaitable[None] | None],
    ) -> ActionServer[G, R, F]:
        server = Ros2ActionServer(
            self.transport, self.rcl, self.resolve(name), action_type, on_goal, on_cancel, self._group
        )
        self.on_shutdown(server.shutdown)
        return server

    def action_client(self, name: str, action_type: ActionType[G, R, F]) -> ActionClient[G, R, F]:
        client = Ros2ActionClient(self.transport, self.rcl, self.resolve(name), action_type, self._group)
        self.on_shutdown(client.close)
        return client

    def get_param(self, name: str, default: Any = None) -> Any:
        return self.transport.get_param(self.resolve(name), default, self.rcl)

    def set_param(self, name: str, value: Any) -> None:
        self.transport.set_param(self.resolve(name), value, self.rcl)

    def shutdown(self) -> None:
        """See :meth:`Node.shutdown`; the rclpy node leaves the graph last."""
        if not self.is_shut_down:
            # Out of the executor first: an action server or client destroyed while the executor
            # still gathers this node's entities left a dead one in its wait set, and every later
            # turn of the executor failed on it ("action server pointer is invalid").
            self.transport.executor.remove_node(self.rcl)
        super().shutdown()

    def _drop_rcl(self) -> None:
        self.transport.drop_rcl_node(self.rcl)
