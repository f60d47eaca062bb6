"""The middleware a robot's parts meet on as ROS nodes: ROS 1 or ROS 2, as one strategy object.

``cyborg node``, ``cyborg launch``, ``cyborg sim --ros/--ros2`` and the command tool's
``--ros/--ros2`` each pick a :class:`Middleware` (:data:`ROS1` or :data:`ROS2`) once, from the
command line, and pass it down whole: it says how to check that the middleware is installed,
how to join its graph (a transport), where a node's log goes, which Python runs a node, which
robot-base interface the graph speaks, and how a launch prepares the graph for its nodes
(:class:`LaunchGraph`: ROS 1 starts a master when none answers and sets ``/use_sim_time``;
ROS 2 has no master and meets its nodes in a folder). Nothing outside :mod:`cyborg.run` and the
transports asks which ROS it is.
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import urllib.parse
import uuid
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, ClassVar

from cyborg.errors import CyborgError
from cyborg.run.census import (
    NameTaken,
    graph_name,
    ros1_live_nodes,
    ros2_domain_problem,
    taken_message,
    wait_for_graph,
)
from cyborg.run.logs import log_to_file, show_problems_on_stderr
from cyborg.run.master import Master, master_running, master_uri, start_master
from cyborg.run.ros2_env import ros2_environment, ros2_python, run_in_ros2_venv
from cyborg.run.simtime import (
    EPOCH_DIR_PREFIX,
    EPOCH_PARAM_PREFIX,
    SIM_PARAMS,
    USE_SIM_TIME,
    FolderRendezvous,
    MasterRendezvous,
    Rendezvous,
)
from cyborg.transport.base import Transport
from cyborg.transport.clock import Clock
from cyborg.transport.topics import CONTROLLER_NODE, BaseApi

__all__ = [
    "ROS1",
    "ROS2",
    "LaunchGraph",
    "Middleware",
    "Ros1",
    "Ros2",
    "require_ros",
    "require_ros2",
]


_NO_ROS1 = (
    "ROS 1 is not available in this environment; fix: run scripts/install-ros, then "
    "`source .venv/bin/activate`"
)
_ROS1_PACKAGES = ("rospy", "actionlib", "cyborg_controller")


def require_ros() -> None:
    """Raise a :class:`CyborgError` that says how to install ROS 1 unless rospy imports here."""
    try:
        import cyborg.transport.ros  # noqa: F401  (imports rospy and actionlib)
    except ImportError:
        raise CyborgError(_NO_ROS1) from None


def _require_ros_installed() -> None:
    """:func:`require_ros` for a process that joins no graph (the launcher): the packages are
    found, not imported. rospy brings actionlib, genpy and numpy, some 20 MiB the launcher would
    carry as long as the robot runs; a node that cannot import them says so itself."""
    if any(importlib.util.find_spec(name) is None for name in _ROS1_PACKAGES):
        raise CyborgError(_NO_ROS1)


def require_ros2() -> None:
    """Raise a :class:`CyborgError` that says how to get ROS 2 unless rclpy imports here."""
    try:
        import cyborg.transport.ros2  # noqa: F401  (imports rclpy and our ROS 2 interfaces)
    except ImportError as exc:
        raise CyborgError(
            f"ROS 2 is not available in this Python ({exc}); fix: run scripts/install-ros2 and use "
            ".venv-ros2/bin/cyborg (a --ros2 command in the main venv runs there by itself)"
        ) from None


def exit_description(code: int | None) -> str:
    """``killed by SIGKILL`` for a negative return code, else ``exit code N``."""
    if code is not None and code < 0:
        with contextlib.suppress(ValueError):
            return f"killed by {signal.Signals(-code).name}"
    return f"exit code {code}"


class LaunchGraph(ABC):
    """What a launch does to the graph around its nodes: prepare it, keep it up, put it back."""

    @abstractmethod
    def open(self, speed: float | None, *, lockstep: bool = False) -> tuple[Rendezvous | None, str | None]:
        """Prepare the graph for nodes in virtual time at ``speed`` (None: real time, unless
        ``lockstep``: granted time, which needs no origin); return where the nodes meet to agree
        on the origin, and the ``--epoch`` argument naming it."""

    def keep_up(self) -> None:
        """Start again what the launch started and what has stopped (called while it supervises)."""
        return None

    def origin_fixed(self, epoch: float) -> None:
        """The launch fixed the origin of virtual time at ``epoch`` (kept for a restarted graph)."""
        return None

    @abstractmethod
    def close(self) -> None:
        """Undo what :meth:`open` did; stop what it started."""


class Middleware(ABC):
    """ROS 1 or ROS 2: how this robot's parts run as nodes of one of them (see the module doc)."""

    name: ClassVar[str]
    """``ROS 1`` or ``ROS 2``, for messages."""
    graph_setting: ClassVar[str]
    """The environment variable that says which graph a process joins."""
    base_api: ClassVar[BaseApi]
    """The robot base's interface on this graph (ROSARNL's on ROS 1, nav2's on ROS 2)."""
    discovers_late: ClassVar[bool]
    """True when a new node sees the others only after discovery (no master to ask at once)."""
    node_arguments: ClassVar[list[str]]
    """What ``cyborg node`` is given to run a node on it."""
    preload: ClassVar[str]
    """What every node of it imports, the launch's zygote imports once: a key of
    :data:`cyborg.run.zygote.PRELOAD`."""
    hosts_many: ClassVar[bool]
    """True when one process may hold several real nodes (rclpy), each its own sender on the
    graph; rospy allows one node per process, whose name every message it sends carries."""

    @abstractmethod
    def require(self) -> None:
        """Raise a :class:`CyborgError` naming the install step unless this Python can join."""

    @abstractmethod
    def transport(
        self, clock: Clock, node_name: str, *, use_sim_time: bool = False, also: Sequence[str] = ()
    ) -> Transport:
        """Join the graph as the process of node ``node_name`` (its log set up as the middleware's),
        which also hosts the nodes ``also`` (only where :attr:`hosts_many`).

        Raises :class:`~cyborg.run.census.NameTaken` when a live node of one of these names is on
        the graph (for the controller's node also: a parameter home there), see :mod:`cyborg.run.census`.
        """

    def graph_name(self) -> str:
        """Which graph this process joins, for people (the launch's first lines, the dashboard)."""
        return graph_name(self.name)

    @abstractmethod
    def tool_transport(self, clock: Clock) -> Transport:
        """Join the graph as a short-lived command-tool process."""

    @abstractmethod
    def log_file(self, node_name: str) -> Path:
        """Where every log line of node ``node_name`` goes."""

    @abstractmethod
    def launch_graph(self, data_dir: Path, say: Callable[[str], None]) -> LaunchGraph:
        """The graph a launch of this middleware prepares (``data_dir``: where a master keeps its log)."""

    def part_built(self, node_name: str) -> None:
        """Node ``node_name``'s part is built (its nodes have joined the graph)."""
        return None

    def python(self) -> str:
        """The interpreter that runs a node process."""
        return sys.executable

    def environment(self) -> dict[str, str] | None:
        """The environment of a node process (None: this one's)."""
        return None

    def enter(self) -> None:
        """Make sure this process can join: run the command again in another Python if need be."""
        return None

    async def see_parameters(self, transport: Transport, timeout: float) -> None:
        """Wait (up to ``timeout``) until the controller's parameters can be read on this graph."""
        return None

    def __repr__(self) -> str:
        return f"<{self.name}>"


class Ros1(Middleware):
    """ROS 1 (rospy from Debian's packages, ``scripts/install-ros``): a master, latched topics."""

    name = "ROS 1"
    graph_setting = "ROS_MASTER_URI"
    base_api = BaseApi.ROSARNL
    discovers_late = False
    node_arguments: ClassVar[list[str]] = []
    preload = "ros1"
    hosts_many = False

    def require(self) -> None:
        require_ros()

    def _check_master(self, fix: str) -> None:
        self.require()
        if not master_running():
            raise CyborgError(f"no ROS master answers at {master_uri()}; fix: {fix}")

    def transport(
        self, clock: Clock, node_name: str, *, use_sim_time: bool = False, also: Sequence[str] = ()
    ) -> Transport:
        if also:
            raise CyborgError(
                f"ROS 1 runs one node per process (rospy), so {node_name} cannot host "
                f"{', '.join(also)}: a gatekeeper tells modules apart by their node's name; fix: run "
                "each as its own `cyborg node`, or use ROS 2 (--ros2), whose processes hold many nodes"
            )
        self._check_master("start roscore, or use `cyborg launch`")
        live = ros1_live_nodes([node_name], master_uri())
        if node_name in live:
            raise NameTaken(taken_message(node_name, self.graph_name(), live[node_name]))
        from cyborg.transport.ros import RosTransport

        return RosTransport(clock, process_name=node_name)

    def part_built(self, node_name: str) -> None:
        # rospy set up its logging when the first node joined: the rest goes to the node's log file.
        show_problems_on_stderr(node_name)

    def tool_transport(self, clock: Clock) -> Transport:
        # rospy logs this INFO line when it is imported: not news to a user of every command (a
        # filter: rospy's logging configuration at init_node resets the loggers' levels, not filters)
        logging.getLogger("rospy.topics").addFilter(_not_topicmanager_initialized)
        self._check_master(
            "start the robot with `cyborg launch` (or `cyborg sim --ros`), or set ROS_MASTER_URI"
        )
        from cyborg.transport.ros import RosTransport

        return RosTransport(clock, process_name=f"cyborg_tool_{os.getpid()}")

    def log_file(self, node_name: str) -> Path:
        import rospkg  # type: ignore[import-not-found]

        return Path(rospkg.get_log_dir()) / f"{node_name}.log"

    def launch_graph(self, data_dir: Path, say: Callable[[str], None]) -> LaunchGraph:
        return _Ros1Graph(data_dir, say)


class Ros2(Middleware):
    """ROS 2 (rclpy from pinned wheels in ``.venv-ros2``, ``scripts/install-ros2``): no master."""

    name = "ROS 2"
    graph_setting = "ROS_DOMAIN_ID"
    base_api = BaseApi.NAV2
    discovers_late = True
    node_arguments: ClassVar[list[str]] = ["--ros2"]
    preload = "ros2"
    hosts_many = True

    def require(self) -> None:
        require_ros2()

    def transport(
        self, clock: Clock, node_name: str, *, use_sim_time: bool = False, also: Sequence[str] = ()
    ) -> Transport:
        self.require()
        problem = ros2_domain_problem()
        if problem is not None:
            raise CyborgError(problem)
        from cyborg.transport.ros2 import Ros2Transport
        from cyborg.transport.ros2.transport import PARAM_HOME

        log_to_file(self.log_file(node_name), node_name, hosted=[self.log_file(name) for name in also])
        transport = Ros2Transport(clock, use_sim_time=use_sim_time)
        wanted = {node_name, *also}
        if node_name == CONTROLLER_NODE:
            wanted.add(PARAM_HOME)
        taken = wait_for_graph(transport.graph_node_names, wanted, own=transport.own_node_names())
        if taken:
            transport.close()
            name = min(taken - {PARAM_HOME}) if taken - {PARAM_HOME} else PARAM_HOME
            raise NameTaken(taken_message(name, self.graph_name(), home=name == PARAM_HOME))
        return transport

    def tool_transport(self, clock: Clock) -> Transport:
        self.require()
        from cyborg.transport.ros2 import Ros2Transport

        return Ros2Transport(clock)

    def log_file(self, node_name: str) -> Path:
        home = Path(os.environ.get("ROS_HOME") or Path.home() / ".ros")
        return Path(os.environ.get("ROS_LOG_DIR") or home / "log") / f"{node_name}.log"

    def launch_graph(self, data_dir: Path, say: Callable[[str], None]) -> LaunchGraph:
        return _Ros2Graph()

    def python(self) -> str:
        return ros2_python()

    def environment(self) -> dict[str, str] | None:
        return ros2_environment()

    def enter(self) -> None:
        run_in_ros2_venv()

    async def see_parameters(self, transport: Transport, timeout: float) -> None:
        """A fresh node may not see the controller's parameter home yet: a read would find nothing."""
        import asyncio

        from cyborg.transport.ros2 import Ros2Transport

        assert isinstance(transport, Ros2Transport)
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while not transport.parameter_home_visible() and loop.time() < deadline:
            await asyncio.sleep(0.02)


def _not_topicmanager_initialized(record: logging.LogRecord) -> bool:
    return record.getMessage() != "topicmanager initialized"


ROS1 = Ros1()
ROS2 = Ros2()


class _Ros1Graph(LaunchGraph):
    """A master if none answers (started again if it stops), and ``/use_sim_time`` set and restored."""

    def __init__(self, data_dir: Path, say: Callable[[str], None]) -> None:
        self.data_dir = data_dir
        self.say = say
        self.master: subprocess.Popen[bytes] | None = None
        self.namespace: str | None = None
        self.speed: float | None = None
        self.lockstep = False
        self.epoch: float | None = None
        self._saved_sim_time: Any = None
        self._touched_sim_time = False

    def open(self, speed: float | None, *, lockstep: bool = False) -> tuple[Rendezvous | None, str | None]:
        _require_ros_installed()
        self.speed = speed
        self.lockstep = lockstep
        if not master_running():
            self.master = start_master(self._port(), self.data_dir / "ros")
            self.say(f"started roscore at {master_uri()}")
        master = Master()
        self._saved_sim_time = master.get(USE_SIM_TIME) if master.has(USE_SIM_TIME) else None
        if lockstep:
            master.set(USE_SIM_TIME, True)
            self._touched_sim_time = True
            return None, None
        if speed is not None:
            self.namespace = f"{SIM_PARAMS}/run_{uuid.uuid4().hex[:12]}"
            master.set(USE_SIM_TIME, True)
            self._touched_sim_time = True
            return MasterRendezvous(self.namespace), EPOCH_PARAM_PREFIX + self.namespace
        if self._saved_sim_time:
            master.set(USE_SIM_TIME, False)  # left over from a simulated run: nodes would wait for /clock
            self._touched_sim_time = True
        return None, None

    @staticmethod
    def _port() -> int:
        return urllib.parse.urlparse(master_uri()).port or 11311

    def origin_fixed(self, epoch: float) -> None:
        self.epoch = epoch

    def keep_up(self) -> None:
        if self.master is None or self.master.poll() is None or master_running():
            return  # (roscore alone gone while its rosmaster answers: nothing to do)
        self.say(
            f"roscore stopped ({exit_description(self.master.returncode)}); starting it again at "
            f"{master_uri()}; the nodes register again by themselves"
        )
        self.master = start_master(self._port(), self.data_dir / "ros")
        master = Master()
        if self.speed is not None or self.lockstep:  # a new master holds no parameters: ours again
            master.set(USE_SIM_TIME, True)
            if self.epoch is not None:
                master.set(f"{self.namespace}/epoch", self.epoch)

    def close(self) -> None:
        try:
            if self.master is None and master_running():
                master = Master()
                if self.namespace is not None:
                    master.delete(self.namespace)
                if self._touched_sim_time:
                    if self._saved_sim_time is None:
                        master.delete(USE_SIM_TIME)
                    else:
                        master.set(USE_SIM_TIME, self._saved_sim_time)
        finally:
            if self.master is not None:
                self.master.send_signal(signal.SIGINT)
                try:
                    self.master.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    self.master.kill()
                    self.master.wait(timeout=5)


class _Ros2Graph(LaunchGraph):
    """No master to start or ask: virtual time's origin is set in a folder of this run."""

    def __init__(self) -> None:
        self.run_dir: Path | None = None

    def open(self, speed: float | None, *, lockstep: bool = False) -> tuple[Rendezvous | None, str | None]:
        ros2_python()  # says how to install ROS 2 when it is not
        problem = ros2_domain_problem()
        if problem is not None:
            raise CyborgError(problem)
        if speed is None:
            return None, None
        self.run_dir = Path(tempfile.mkdtemp(prefix="cyborg-launch-"))
        return FolderRendezvous(self.run_dir), EPOCH_DIR_PREFIX + str(self.run_dir)

    def close(self) -> None:
        if self.run_dir is not None:
            shutil.rmtree(self.run_dir, ignore_errors=True)
