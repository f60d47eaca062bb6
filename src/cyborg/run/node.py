"""One part of the robot as one ROS node process (``cyborg node NAME``): build, wait, serve.

:func:`run_node` runs in three steps, each its own function: :func:`build_node` joins the
middleware's graph and builds the part (or the ``cyborg_scenario`` node) with the composition
root (:mod:`cyborg.app.parts`), plus the ``/clock`` and controller-statistics publishers;
:func:`await_start` waits for the topics' connections and for the launch's shared origin of
virtual time (:mod:`cyborg.run.simtime`); :func:`serve_node` runs the part until SIGINT/SIGTERM
(the ``cyborg_api`` part serves the HTTP API and dashboard, :mod:`cyborg.web.build`; the
``cyborg_recorder`` part records what it hears of the graph, :mod:`cyborg.observe.recorder`) and says
with its exit code how it ended. Everything a node is told comes in one :class:`NodeOptions`.
"""

from __future__ import annotations

import asyncio
import logging
import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from cyborg.app.context import BuildContext
from cyborg.app.parts import API, CONTROLLER, RECORDER, SCENARIO, Part, build_part
from cyborg.app.tuning import freeze_built
from cyborg.errors import CyborgError
from cyborg.run.middleware import Middleware
from cyborg.run.simtime import CLOCK_TOPIC, SimTime, is_simulated_base, publish_clock, wait_for_epoch
from cyborg.run.tasks import watch_tasks
from cyborg.transport import topics
from cyborg.transport.base import Publisher, Transport
from cyborg.transport.clock import Clock, VirtualClock
from cyborg.transport.graph import acting_nodes
from cyborg.transport.lockstep import LockstepClock
from cyborg.transport.messages import Clock as ClockMessage
from cyborg.transport.messages import String
from cyborg.web.access import DEFAULT_PORT, Access

if TYPE_CHECKING:
    from cyborg.app.config import LoadedConfig
    from cyborg.app.registry import KindRegistry
    from cyborg.app.sketch import ConfigSketch
    from cyborg.observe.recorder import Recorder, RecorderSettings
    from cyborg.run.scenario import ScenarioFiles, ScenarioNode
    from cyborg.web.api import RobotAPI

__all__ = ["ApiOptions", "BuiltNode", "NodeOptions", "await_start", "build_node", "run_node", "serve_node"]

log = logging.getLogger(__name__)

CONNECT_TIMEOUT = 5.0  # real seconds a node waits for its topics' connections before it starts


@dataclass(frozen=True)
class ApiOptions:
    """Where the ``cyborg_api`` part serves the HTTP API and dashboard, and who may use it."""

    host: str = "127.0.0.1"
    port: int = DEFAULT_PORT
    access: Access | None = None


@dataclass(frozen=True)
class NodeOptions:
    """Everything ``cyborg node`` (or a launch, through it) tells one node: built once, passed whole."""

    config: LoadedConfig | ConfigSketch
    """The whole validated configuration; a module's or gatekeeper's node started by a launch gets
    a sketch of it (:mod:`cyborg.app.sketch`): the launch validated it."""
    data_dir: Path
    map_path: Path | None = None
    seed: int = 0
    resume: bool = True
    """The controller may take over a recently stored emotion (``--fresh`` turns it off)."""
    time: SimTime = field(default_factory=SimTime)
    publish_clock: bool | None = None
    """Publish /clock (with a speed only); None: when the part is a simulated base."""
    api: ApiOptions = field(default_factory=ApiOptions)
    scenario: ScenarioFiles | None = None
    """What ``cyborg_scenario`` plays; only that part reads it."""
    record: RecorderSettings | None = None
    """Where ``cyborg_recorder`` records; only that part reads it."""
    also: tuple[str, ...] = ()
    """Modules and gatekeepers this process hosts beside NAME, each its own node on the graph
    (ROS 2 only: :attr:`Middleware.hosts_many`; ``cyborg launch``'s shared processes)."""
    kinds: KindRegistry | None = None
    """The module kinds the parts are built with (None: every installed package's)."""


@dataclass
class BuiltNode:
    """A node's process after :func:`build_node`: its graph, clock and part, not yet started."""

    name: str
    middleware: Middleware
    clock: Clock
    transport: Transport
    context: BuildContext
    part: Part
    scenario: ScenarioNode | None = None
    clock_publisher: Publisher[ClockMessage] | None = None
    stats_publisher: Publisher[String] | None = None

    def close(self) -> None:
        """Close the part (its periodic work stops before its publishers go), leave the graph, stop the clock."""
        try:
            self.part.close()
        finally:
            self.transport.close()
            self.clock.close()


def run_node(name: str, options: NodeOptions, middleware: Middleware) -> int:
    """Run part ``name`` as the node of the same name until SIGINT/SIGTERM; return the exit code.

    ``cyborg_scenario`` (with ``options.scenario``) plays its script and ends with it.
    """
    node = build_node(name, options, middleware)
    try:
        if not await_start(node, options.time):
            return 0
        return node.clock.run(serve_node(node, options))
    finally:
        node.close()


def build_node(name: str, options: NodeOptions, middleware: Middleware) -> BuiltNode:
    """Join ``middleware``'s graph as node ``name`` and build its part, not started yet."""
    for other in options.also:
        if other == RECORDER and name == API:
            continue  # both only listen to the graph (cyborg launch --ros2 shares their process)
        if other in (CONTROLLER, API, RECORDER, SCENARIO) or is_simulated_base(options.config, other):
            raise CyborgError(
                f"{other} runs in a process of its own (the recorder may share the API's); fix: host "
                f"only modules and gatekeepers beside {name}"
            )
    clock = options.time.make_clock()
    transport = middleware.transport(clock, name, use_sim_time=options.time.virtual, also=options.also)
    context = BuildContext(
        data_dir=options.data_dir,
        seed=options.seed,
        map_path=options.map_path,
        resume=options.resume,
        base_api=middleware.base_api,
    )
    node = BuiltNode(name, middleware, clock, transport, context, Part(name))
    if name == SCENARIO:
        from cyborg.run.scenario import ScenarioNode

        if options.scenario is None:
            raise CyborgError(f"{SCENARIO} plays a script; fix: give it --script FILE")
        node.scenario = ScenarioNode(transport.node(SCENARIO), options.scenario)
        node.part = Part(name, [node.scenario])
    else:
        try:
            node.part = build_part(name, options.config, transport, context, kinds=options.kinds)
            for other in options.also:  # one process, one loop; each part its own node(s)
                hosted = build_part(other, options.config, transport, context, kinds=options.kinds)
                node.part.components += hosted.components
        except BaseException:
            node.close()  # leave the graph: the error is the node's whole output
            raise
    middleware.part_built(name)
    publish = options.publish_clock
    if publish is None:
        publish = is_simulated_base(options.config, name)
    if publish and options.time.virtual:
        # Made now, so every node is connected when the time starts (they all wait for /clock).
        node.clock_publisher = transport.node(f"{name}_clock").publisher(
            CLOCK_TOPIC, ClockMessage, queue_size=1
        )
    if node.part.controller is not None:  # its counters, for the cyborg_api node's dashboard
        node.stats_publisher = node.part.controller.node.publisher(
            topics.CONTROLLER_STATS, String, latch=True
        )
    return node


def await_start(node: BuiltNode, sim_time: SimTime) -> bool:
    """Wait for the topics' connections, then for the shared origin of virtual time and its
    moment; False when interrupted (Ctrl-C) meanwhile."""
    missing = node.transport.wait_for_connections(CONNECT_TIMEOUT)
    if missing:  # e.g. a node killed without leaving the graph: the node starts anyway
        log.warning(
            "%d connection(s) not made within %.0f s, whose first messages may be lost: %s",
            len(missing),
            CONNECT_TIMEOUT,
            "; ".join(missing[:5]) + (" ..." if len(missing) > 5 else ""),
        )
    clock = node.clock
    try:
        if isinstance(clock, LockstepClock):
            clock.join(node.name, node.transport.node_names())  # once every node of the launch has
            return True
        rendezvous = sim_time.rendezvous
        if rendezvous is not None:
            assert isinstance(clock, VirtualClock)
            clock.anchor(wait_for_epoch(rendezvous, node.name))
        if isinstance(clock, VirtualClock) and clock.real_origin > time.time():
            time.sleep(clock.real_origin - time.time())  # everyone starts at the origin
    except KeyboardInterrupt:
        return False
    return True


async def serve_node(node: BuiltNode, options: NodeOptions) -> int:
    """Run the built node until SIGINT/SIGTERM (or its script's end); the process's exit code."""
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    background: list[asyncio.Task[None]] = []
    if node.clock_publisher is not None and isinstance(node.clock, LockstepClock):
        clock, clock_publisher = node.clock, node.clock_publisher
        clock.on_advance.append(lambda: clock_publisher.publish(ClockMessage(clock.now())))
        clock_publisher.publish(ClockMessage(clock.now()))
        graph = getattr(node.transport, "graph", None)
        if callable(graph):  # the nodes outside the lockstep: /clock's publisher looks for them
            clock.watch_graph(lambda: acting_nodes(graph(ask_nodes=False)))
    elif node.clock_publisher is not None:
        assert isinstance(node.clock, VirtualClock)
        background.append(loop.create_task(publish_clock(node.clock_publisher, node.clock), name="clock"))
    controller = node.part.controller
    if node.stats_publisher is not None and controller is not None:
        from cyborg.web.ros_view import publish_controller_stats

        counters = publish_controller_stats(node.stats_publisher, controller)
        background.append(loop.create_task(counters, name="controller stats"))
    api = await _serve_api(node, options) if node.name == API else None
    recorder = _start_recorder(node, options) if RECORDER in (node.name, *options.also) else None
    freeze_built()  # what the part built lives as long as the node: out of GC's way (app.tuning)
    controller_task = controller.start() if controller is not None else None
    tasks = watch_tasks(node.clock)  # a module leaking tasks is named (cyborg.run.tasks)
    _tell(f"node {node.name} running")
    if node.scenario is not None:
        try:
            return await _play(node.scenario, stop, node.name)
        finally:
            tasks.cancel()
    waiter = asyncio.ensure_future(stop.wait())
    await asyncio.wait(
        {waiter, *([controller_task] if controller_task else [])}, return_when=asyncio.FIRST_COMPLETED
    )
    waiter.cancel()
    tasks.cancel()
    code = 0
    if controller_task is not None and controller_task.done():
        # It logged why (critical). Leave, so that `cyborg launch` (or roslaunch's respawn) starts it again.
        _tell(f"node {node.name}: the controller stopped; ending this node with exit code 1")
        code = 1
    elif controller is not None:
        await controller.stop()
    if api is not None:
        await api.stop()
    if recorder is not None:
        recorder.close()  # the file's summary and index: a finished, seekable recording
        _tell(f"node {node.name}: recorded to {recorder.files[-1] if recorder.files else '-'}")
    return code


def _start_recorder(node: BuiltNode, options: NodeOptions) -> Recorder | None:
    """The flight recorder of the graph, from now on (the clock is set: records start at 0)."""
    from cyborg.observe.recorder import Recorder, RunFacts
    from cyborg.observe.records import RecordStream, to_ns
    from cyborg.observe.rosout import hear_ros_logs
    from cyborg.run.local import clock_kind

    if options.record is None:
        _tell(f"node {node.name}: recording is off (--no-record); it records nothing")
        return None
    config = _validated(options)
    recorder_node = node.transport.node(RECORDER)
    facts = RunFacts(
        start_ns=to_ns(node.clock.now()),
        clock=clock_kind(node.clock),
        seed=options.seed,
        config_name=Path(config.source).name or "config.yaml",
        config_text=config.text,
        extra={"middleware": node.middleware.name},
    )
    has_base = any(
        isinstance(m, dict) and m.get("kind") == "simulated_base" for m in config.model.modules.values()
    )
    occupancy = node.context.occupancy_map() if has_base else None
    recorder = Recorder(
        recorder_node, RecordStream(recorder_node), options.record, facts, occupancy=occupancy
    )
    node.part.components.append(recorder)  # closed with the part: its node leaves the graph
    hear_ros_logs(recorder, node.middleware.name)  # the other nodes' warnings and errors (/rosout)
    _tell(f"node {node.name}: recording to {recorder.path or recorder.problem}")
    return recorder


async def _serve_api(node: BuiltNode, options: NodeOptions) -> RobotAPI:
    """The HTTP API and dashboard over a mirror of the robot read from the graph."""
    import click

    from cyborg.web.build import build_api, start_api
    from cyborg.web.ros_view import remote_robot

    config = _validated(options)
    api_node = node.transport.node(API)
    has_base = any(
        isinstance(m, dict) and m.get("kind") == "simulated_base" for m in config.model.modules.values()
    )
    mirror = remote_robot(api_node, config, node.context.occupancy_map() if has_base else None)
    graph = node.middleware.graph_name()  # which graph the dashboard shows: another robot's is not this one
    api = build_api(
        api_node,
        config,
        mirror,
        access=options.api.access,
        extra_status=lambda: {"emotion_enabled": mirror.emotion_enabled(), "graph": graph},
    )
    await start_api(
        api,
        options.api.host,
        options.api.port,
        lambda text, colour: click.secho(text, fg=colour, err=True),
        token_given=options.api.access is not None and options.api.access.token is not None,
    )
    return api


def _validated(options: NodeOptions) -> LoadedConfig:
    from cyborg.app.config import LoadedConfig

    if not isinstance(options.config, LoadedConfig):
        raise CyborgError("this part reads the whole validated configuration, not a sketch of it")
    return options.config


async def _play(scenario: ScenarioNode, stop: asyncio.Event, name: str) -> int:
    run = asyncio.ensure_future(scenario.play())
    waiter = asyncio.ensure_future(stop.wait())
    await asyncio.wait({run, waiter}, return_when=asyncio.FIRST_COMPLETED)
    waiter.cancel()
    if not run.done():
        run.cancel()
        return 1
    run.result()
    import click

    _tell(f"node {name}: script ended, {scenario.driver.count} records")
    click.secho(f"{name}: {scenario.driver.summary()}", fg="green")  # in the launch's terminal
    return 0


def _tell(line: str) -> None:
    """A line on stderr, as ``click.echo(err=True)`` writes it (a thin node imports no click)."""
    print(line, file=sys.stderr, flush=True)
