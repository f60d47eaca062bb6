"""``cyborg doctor``: does this machine, and the ROS graph it is on, have what a configuration needs?

Each check is one line: passed, or failed with the fix. Without a middleware only the machine is
checked (the configuration and its module kinds, the data folder, the speaker, the microphone);
with ROS 1 or ROS 2 also the graph: the master (or the DDS domain), every state's action server,
the robot base's action, services and pose (and the pose's rate), the speech output's node, the
clock (simulated or real) in every node, the configured nodes the graph lacks and the nodes on the
graph that no state uses (a note: it does not fail the doctor). The graph is the one this process
joins (``ROS_MASTER_URI`` / ``ROS_DOMAIN_ID``); the speaker and microphone are this machine's, so
the doctor is meant to run on the robot's computer. The graph checks run side by side, so a
missing part costs the doctor one timeout, not one per part.
"""

from __future__ import annotations

import asyncio
import enum
import functools
import json
import os
import shutil
import tempfile
import time
from collections.abc import Awaitable, Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cyborg.app.config import LoadedConfig
from cyborg.app.parts import API, CONTROLLER
from cyborg.app.registry import KindRegistry, module_kinds
from cyborg.errors import CyborgError
from cyborg.transport import topics
from cyborg.transport.base import Node
from cyborg.transport.clock import RealClock
from cyborg.transport.graph import GraphView
from cyborg.transport.messages import (
    EmptyService,
    MoveBaseAction,
    NavigateToPoseAction,
    PoseWithCovarianceStamped,
    StateMachineAction,
)
from cyborg.transport.topics import BaseApi

if TYPE_CHECKING:
    from cyborg.run.middleware import Middleware

__all__ = ["Check", "CheckStatus", "DoctorReport", "run_doctor"]

WAIT = 2.0
"""Seconds the doctor waits for a server, a pose or discovery before a check fails."""
ROS2_WAIT = 5.0
"""The same on ROS 2, where discovery of a new client's server took over 2 s on a loaded machine."""
POSE_WINDOW = 1.0
"""Seconds of pose messages the rate is measured over."""
MIN_FREE_MB = 200.0
"""Free space the data folder needs (a day of recordings, the databases)."""
CLOCK = "/clock"
DISCOVERY_WAIT = 8.0
"""ROS 2: seconds the doctor waits for discovery to show the controller (a graph of 30 nodes took
5 s to show on a loaded 2-core machine)."""
OURS = (
    "cyborg_doctor",
    "cyborg_tool",
    "rosout",
    "rosarnl_node_clock",
    "_",
    "cyborg_emotion",
    "cyborg_motivator",
    "cyborg_parameter",
)
"""Name starts of nodes that are the tools', the controller's own (its emotion system, motivator
and parameters are nodes of their own on ROS 2) or the middleware's: never "unused"."""


class CheckStatus(enum.StrEnum):
    """How one check went; a NOTE is worth knowing but does not fail the doctor."""

    PASSED = "passed"
    FAILED = "failed"
    NOTE = "note"


@dataclass
class Check:
    """One line of the doctor's answer."""

    name: str
    status: CheckStatus
    detail: str
    fix: str = ""
    seconds: float = 0.0

    def line(self) -> str:
        mark = {CheckStatus.PASSED: "ok  ", CheckStatus.FAILED: "FAIL", CheckStatus.NOTE: "note"}[self.status]
        fix = f"; fix: {self.fix}" if self.fix else ""
        return f"{mark} {self.name}: {self.detail}{fix} ({self.seconds:.1f} s)"


def _passed(name: str, detail: str) -> Check:
    return Check(name, CheckStatus.PASSED, detail)


def _failed(name: str, detail: str, fix: str) -> Check:
    return Check(name, CheckStatus.FAILED, detail, fix)


@dataclass
class DoctorReport:
    """Every check, in the order they are printed."""

    checks: list[Check] = field(default_factory=list)
    seconds: float = 0.0
    """How long the doctor took in all (its graph checks run side by side)."""

    @property
    def passed(self) -> bool:
        return all(check.status is not CheckStatus.FAILED for check in self.checks)

    def failed(self) -> list[Check]:
        return [check for check in self.checks if check.status is CheckStatus.FAILED]

    def text(self) -> str:
        failed = len(self.failed())
        summary = "all checks passed" if not failed else f"{failed} of {len(self.checks)} checks failed"
        summary += f" ({self.seconds:.1f} s)"
        return "\n".join([*(check.line() for check in self.checks), summary])

    def to_json(self) -> str:
        checks = [
            {**asdict(c), "status": c.status.value, "seconds": round(c.seconds, 3)} for c in self.checks
        ]
        return json.dumps(
            {"passed": self.passed, "seconds": round(self.seconds, 3), "checks": checks}, indent=2
        )


Judge = Callable[[GraphView], Check]
"""A check whose waiting is done, judged on one look at the graph."""


async def _waited(wait: Awaitable[Judge]) -> tuple[Judge, float]:
    started = time.monotonic()
    judge = await wait
    return judge, time.monotonic() - started


def _timed_now(make: Callable[[], Check]) -> Check:
    started = time.monotonic()
    check = make()
    check.seconds = time.monotonic() - started
    return check


# --- what the configuration needs ---------------------------------------------------------------


@dataclass
class Needs:
    """What a configuration asks of the machine and the graph."""

    config: LoadedConfig
    actions: dict[str, str] = field(default_factory=dict)
    """Each leaf state's action -> the state."""
    servers: dict[str, str] = field(default_factory=dict)
    """Action -> the configured module that serves it."""
    settings: dict[str, tuple[str, Any]] = field(default_factory=dict)
    """Module node -> (kind name, settings)."""

    @classmethod
    def of(cls, config: LoadedConfig, registry: KindRegistry) -> Needs:
        needs = cls(config)
        for leaf in config.machine.leaves():
            assert leaf.action is not None
            needs.actions["/" + leaf.action.lstrip("/")] = leaf.name
        for name, raw in config.model.modules.items():
            _, settings = registry.parse(name, raw, source=config.source)
            needs.settings[name] = (str(raw["kind"]), settings)
            for action in settings.serves():
                needs.servers["/" + action.lstrip("/")] = name
        return needs

    def of_kind(self, kind: str) -> list[tuple[str, Any]]:
        return [(name, settings) for name, (k, settings) in self.settings.items() if k == kind]

    def nodes(self) -> list[str]:
        """The nodes the configuration starts (``cyborg launch``'s parts but the API)."""
        return [CONTROLLER, *self.config.model.modules, *(g.name for g in self.config.model.gatekeepers)]


# --- the machine --------------------------------------------------------------------------------


def machine_checks(needs: Needs, data_dir: Path) -> list[Check]:
    """The data folder, the speaker and the microphone of this machine, as the configuration uses them."""
    checks = [_timed_now(lambda: _data_folder(data_dir))]
    for name, settings in needs.of_kind("tts"):
        if settings.play_audio is not False:
            # play_audio unset: the module speaks aloud only where a sound device is, silently elsewhere
            speaker = functools.partial(_speaker, name, required=settings.play_audio is True)
            checks.append(_timed_now(speaker))
    for name, settings in needs.of_kind("speech_input"):
        if settings.source == "microphone":
            checks.append(_timed_now(functools.partial(_microphone, name, settings.device)))
    return checks


def _data_folder(folder: Path) -> Check:
    name = f"data folder {folder}"
    fix = "give a writable folder with --db, or set CYBORG_DATA_DIR"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".doctor-"):
            pass
        free = shutil.disk_usage(folder).free / 1e6
    except OSError as exc:
        return _failed(name, f"not writable ({exc.strerror or exc})", fix)
    if free < MIN_FREE_MB:
        return _failed(
            name, f"only {free:.0f} MB free", f"free at least {MIN_FREE_MB:.0f} MB on that disk, or {fix}"
        )
    return _passed(name, f"writable, {free / 1000:.1f} GB free")


def _speaker(module: str, *, required: bool = True) -> Check:
    from cyborg.modules.speech import probe_sound_output

    problem = probe_sound_output()
    if problem is None:
        return _passed(f"speech output ({module})", "espeak-ng plays on the default sound device")
    what, _, fix = problem.partition("; fix: ")
    if not required:
        what += " (play_audio is not set: the module speaks silently here)"
        return Check(
            f"speech output ({module})", CheckStatus.NOTE, what, "set play_audio: true to require it"
        )
    return _failed(f"speech output ({module})", what, fix)


def _microphone(module: str, device: str | None) -> Check:
    from cyborg.hearing import HearingError
    from cyborg.hearing.audio import probe_microphone

    try:
        found = probe_microphone(device)
    except HearingError as exc:
        what, _, fix = str(exc).partition("; fix: ")
        return _failed(f"microphone ({module})", what, fix)
    return _passed(f"microphone ({module})", f"input device {found!r}")


# --- the graph ----------------------------------------------------------------------------------


class GraphDoctor:
    """The graph checks of one configuration, on one node of the middleware's graph."""

    def __init__(
        self, needs: Needs, middleware: Middleware, node: Node, graph: Callable[[], GraphView]
    ) -> None:
        self.needs = needs
        self.middleware = middleware
        self.node = node
        self.graph = graph
        self.ros2 = middleware.discovers_late
        self.wait = ROS2_WAIT if self.ros2 else WAIT
        self.launch = " ".join(["cyborg launch", *middleware.node_arguments])
        self.joined = 0.0
        """Seconds it took to join the graph (counted to the graph's check)."""

    def start_node(self, name: str) -> str:
        args = " ".join(self.middleware.node_arguments)
        return (
            f"start it: `cyborg node {name} --config {self.needs.config.source}{' ' + args if args else ''}`"
        )

    async def run(self) -> list[Check]:
        """Wait for every server and the pose side by side, then judge them on one look at the graph."""
        started = time.monotonic()
        await self._discover()
        waits: list[Awaitable[Judge]] = [
            self._action(action, state) for action, state in self.needs.actions.items()
        ]
        base = self._base_api()
        if base is not None:
            waits += self._base_waits(base)
        judges = await asyncio.gather(*(_waited(wait) for wait in waits))
        view = self.graph()
        checks = [self._reach(view, self.joined + time.monotonic() - started)]
        for judge, seconds in judges:
            check = judge(view)
            check.seconds = seconds
            checks.append(check)
        checks += [_timed_now(lambda: self._speech_node(view)), _timed_now(lambda: self._clock(view))]
        return checks + self._nodes(view)

    def _reach(self, view: GraphView, seconds: float) -> Check:
        if not view.nodes:
            where = "ROS_DOMAIN_ID (and ROS_AUTOMATIC_DISCOVERY_RANGE)" if self.ros2 else "ROS_MASTER_URI"
            reach = _failed(
                "graph",
                f"no node seen within {self.wait:g} s",
                f"start the robot (`{self.launch} --config {self.needs.config.source}`), or set {where} "
                "as the robot's nodes have it",
            )
        else:
            seen = [n for n in self.needs.nodes() if n in view.nodes]
            reach = _passed("graph", f"{len(view.nodes)} nodes, {len(seen)} of them the robot's")
        reach.seconds = seconds
        return reach

    async def _discover(self) -> None:
        """ROS 2: wait (up to DISCOVERY_WAIT) until discovery shows the controller."""
        if not self.ros2:
            return
        deadline = time.monotonic() + DISCOVERY_WAIT
        while time.monotonic() < deadline:
            if CONTROLLER in self.graph().nodes:
                await asyncio.sleep(0.3)  # the rest of the graph arrives with it
                return
            await asyncio.sleep(0.05)

    def _serving(self, view: GraphView, action: str) -> tuple[list[str], list[str]]:
        """The nodes serving ``action`` by the graph, and those of them that answer."""
        status = f"{action}/_action/status" if self.ros2 else f"{action}/status"
        serving = view.publishers_of(status)
        return serving, [n for n in serving if view.alive(n)]

    async def _action(self, action: str, state: str) -> Judge:
        up = await self.node.action_client(action, StateMachineAction).wait_for_server(self.wait)

        def judge(view: GraphView) -> Check:
            name = f"state {state}: action server {action}"
            module = self.needs.servers.get(action)
            fix = self.start_node(module) if module else f"start the module node that serves {action}"
            serving, alive = self._serving(view, action)
            if up and (alive or (self.ros2 and not serving)):
                return _passed(name, f"served by {', '.join(alive) or module or 'a node'}")
            if serving and not alive:
                return _failed(
                    name, f"{', '.join(serving)} is registered but does not answer (stopped?)", fix
                )
            return _failed(
                name, "no node serves it" + (f" (module {module} is missing)" if module else ""), fix
            )

        return judge

    def _base_api(self) -> BaseApi | None:
        navigation = self.needs.of_kind("navigation")
        if not navigation:
            return None
        api = navigation[0][1].base_api
        return BaseApi(api) if api is not None else self.middleware.base_api

    def _base_waits(self, api: BaseApi) -> list[Awaitable[Judge]]:
        fix = "start the base's node (ROSARNL on the Cyborg: docs/robot.md)"
        waits: list[Awaitable[Judge]] = [self._pose(fix)]
        if api is BaseApi.NAV2:
            waits.append(self._base_action(topics.NAVIGATE_TO_POSE, NavigateToPoseAction, fix))
        else:
            waits.append(self._base_action(topics.MOVE_BASE, MoveBaseAction, fix))
            waits.append(self._base_service(topics.WANDER, fix))
            waits.append(self._base_service(topics.STOP, fix))
        return waits

    async def _base_action(self, action: str, kind: Any, fix: str) -> Judge:
        up = await self.node.action_client(action, kind).wait_for_server(self.wait)

        def judge(view: GraphView) -> Check:
            name = f"robot base: action {action}"
            serving, alive = self._serving(view, action)
            if up and (alive or (self.ros2 and not serving)):
                return _passed(name, f"served by {', '.join(alive) or 'the base'}")
            return _failed(name, "no node serves it: the robot cannot drive", fix)

        return judge

    async def _base_service(self, service: str, fix: str) -> Judge:
        up = await self.node.service_proxy(service, EmptyService).wait_for_service(self.wait)

        def judge(view: GraphView) -> Check:
            name = f"robot base: service {service}"
            alive = [n for n in view.servers_of(service) if view.alive(n)]
            if up and alive:
                return _passed(name, f"served by {', '.join(alive)}")
            return _failed(name, "no node serves it: the robot cannot wander or stop wandering", fix)

        return judge

    async def _pose(self, fix: str) -> Judge:
        stamps: list[float] = []
        subscription = self.node.subscribe(
            topics.AMCL_POSE, PoseWithCovarianceStamped, lambda m, i: stamps.append(time.monotonic())
        )
        try:
            deadline = time.monotonic() + self.wait
            while not stamps and time.monotonic() < deadline:
                await asyncio.sleep(0.05)
            first = len(stamps)
            if stamps:
                await asyncio.sleep(POSE_WINDOW)
        finally:
            subscription.unsubscribe()
        rate = (len(stamps) - first) / POSE_WINDOW

        def judge(view: GraphView) -> Check:
            name = f"robot base: pose {topics.AMCL_POSE}"
            publishers = [n for n in view.publishers_of(topics.AMCL_POSE) if view.alive(n)]
            if not stamps or not publishers:
                return _failed(
                    name, f"no pose within {self.wait:g} s: the robot does not know where it is", fix
                )
            still = " (a pose only when it moves: standing still?)" if rate < 1 else ""
            return _passed(name, f"from {', '.join(publishers)}, {rate:.1f} Hz{still}")

        return judge

    def _speech_node(self, view: GraphView) -> Check:
        outputs = self.needs.of_kind("tts")
        if not outputs:
            return _passed("speech output node", "the configuration has no text-to-speech module")
        name, settings = outputs[0]
        topic = getattr(settings, "input_topic", topics.SPEECH_INPUT_TOPIC)
        listening = [n for n in view.subscribers_of(topic) if view.alive(n)]
        if name in listening:
            return _passed(f"speech output node {name}", f"listens on {topic}")
        return _failed(
            f"speech output node {name}",
            f"no live node {name} listens on {topic}: the robot says nothing aloud",
            self.start_node(name),
        )

    def _clock(self, view: GraphView) -> Check:
        ours = [n for n in self.needs.nodes() if view.alive(n)]
        simulated = sorted(n for n in ours if CLOCK in view.nodes[n].subscribes)
        real = sorted(set(ours) - set(simulated))
        publishers = view.publishers_of(CLOCK)
        if simulated and real:
            return _failed(
                "clock",
                f"simulated in {', '.join(simulated)} but real in {', '.join(real)}",
                "stop the robot and start it again with one `cyborg launch` (with or without --speed)",
            )
        if simulated and not publishers:
            return _failed(
                "clock",
                "the nodes wait for /clock and nobody publishes it",
                f"start the robot with `{self.launch}`",
            )
        if simulated:
            return _passed("clock", f"simulated in every node, from {', '.join(publishers)}")
        if not real:
            return _passed("clock", "no node of the robot to compare")
        return _passed("clock", f"real time in every node of the robot ({len(real)})")

    def _nodes(self, view: GraphView) -> list[Check]:
        checks: list[Check] = []
        missing = [n for n in self.needs.nodes() if not view.alive(n)]
        listed_dead = [n for n in missing if n in view.nodes]
        if missing:
            checks.append(
                _failed(
                    "configured nodes",
                    f"missing from the graph: {', '.join(missing)}"
                    + (f" ({', '.join(listed_dead)} registered but not answering)" if listed_dead else ""),
                    f"start them (`{self.launch} --config {self.needs.config.source}` starts every one)",
                )
            )
        else:
            checks.append(
                _passed("configured nodes", f"all {len(self.needs.nodes())} on the graph and answering")
            )
        used = set(self.needs.nodes()) | {API}
        for action in (topics.MOVE_BASE, topics.NAVIGATE_TO_POSE):
            used.update(self._serving(view, action)[0])
        used.update(view.publishers_of(topics.AMCL_POSE))
        unused = sorted(n for n in view.nodes if n not in used and not n.split("/")[-1].startswith(OURS))
        if unused:
            checks.append(
                Check(
                    "other nodes",
                    CheckStatus.NOTE,
                    f"on the graph but no state uses them: {', '.join(unused)}",
                    "add a state for a student's module (docs/modules.md), or stop the node",
                )
            )
        return checks


def run_doctor(config: LoadedConfig, middleware: Middleware | None, data_dir: Path) -> DoctorReport:
    """Check the machine, and with ``middleware`` its graph, against ``config``."""
    started = time.monotonic()
    report = _checks(config, middleware, data_dir)
    report.seconds = time.monotonic() - started
    return report


def _checks(config: LoadedConfig, middleware: Middleware | None, data_dir: Path) -> DoctorReport:
    report = DoctorReport()
    started = time.monotonic()
    try:
        registry = module_kinds()
        registry.check(config.model.modules, source=config.source)
        needs = Needs.of(config, registry)
    except CyborgError as exc:
        report.checks.append(_failed("configuration", str(exc), "fix the file (`cyborg validate FILE`)"))
        return report
    report.checks.append(
        Check(
            "configuration",
            CheckStatus.PASSED,
            f"{config.source}: {len(needs.actions)} states, {len(config.model.modules)} modules",
            seconds=time.monotonic() - started,
        )
    )
    report.checks += machine_checks(needs, data_dir)
    if middleware is None:
        return report
    report.checks += _join_and_check(needs, middleware)
    return report


def _join_and_check(needs: Needs, middleware: Middleware) -> list[Check]:
    started = time.monotonic()
    graph_name = "ROS master" if not middleware.discovers_late else "ROS 2 domain"
    try:
        middleware.require()
    except CyborgError as exc:
        what, _, fix = str(exc).partition("; fix: ")
        return [_failed(f"{middleware.name} installed", what, fix)]
    if not middleware.discovers_late:
        from cyborg.run.master import master_running, master_uri

        if not master_running():
            return [
                _failed(
                    graph_name,
                    f"no master answers at {master_uri()}",
                    "start the robot (`cyborg launch`) or roscore, or set ROS_MASTER_URI (and ROS_IP) "
                    "to the robot computer's",
                )
            ]
        where = f"answers at {master_uri()}"
    else:
        where = f"ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID', '0')}"
    clock = RealClock()
    try:
        transport = middleware.tool_transport(clock)
        try:
            node = transport.node("cyborg_doctor")
            graph: Callable[[], GraphView] = transport.graph  # type: ignore[attr-defined]
            doctor = GraphDoctor(needs, middleware, node, graph)
            doctor.joined = time.monotonic() - started
            checks = clock.run(doctor.run())
        finally:
            transport.close()
    finally:
        clock.close()
    checks[0].name = graph_name
    if checks[0].status is CheckStatus.PASSED:
        checks[0].detail = f"{where}; {checks[0].detail}"
    return checks
