"""Node processes forked from one that has imported, once, what every node imports.

``cyborg launch`` runs each part as a process of its own (ROS 1: one rospy node per process).
Most of a thin node's start-up is imports (rospy, actionlib, the messages, pydantic, the
transport) and much of its memory is what they leave behind. So the launch starts one *zygote*
(as Android starts its apps): a process that imports those modules and then waits. For each node
it forks a child that runs ``cyborg node NAME ...`` as a freshly started process would, with the
modules already there: their pages stay shared with the zygote and the other nodes until a
process writes to them (copy on write). Every node is still its own process and, on ROS 1, its
own rospy node: its own name on the graph, its own crash, its own restart.

The zygote is single-threaded and joins no graph (a fork keeps only the forking thread). It reads
one request a line on stdin (JSON: the node's ``argv`` and the module that runs it,
``cyborg.cli`` or for a thin part ``cyborg.run.launched``), answers on its control pipe with the
child's pid, and reports each child's exit there too (JSON lines). :class:`Zygote` is the launch's
side; :class:`ForkedNode` stands for one child as a :class:`subprocess.Popen` does (``poll``,
``wait``, ``send_signal``, ``kill``). Ctrl-C reaches the nodes as before (one process group); the
zygote ignores it and ends when the launch closes its stdin.

Once the launch has started every node it asks the zygote to slim down (:meth:`Zygote.slim`): its
children have written to most of the pages they shared with it (Python counts references in its
objects), so its copy of the imports was memory only it used (22 MiB of a ROS 2 launch's PSS).
It then runs again as a small process (``exec``: the same pid, the same children, whose exits it
still reports) that starts a node it is asked for afresh, ``python -m cyborg.cli ARGV``: a node
the launch starts again after it stopped takes its imports' time again.

Run as ``python -m cyborg.run.zygote CONTROL_FD ros1|ros2|fresh``. ``ps -e`` (the command's name, not
its line) shows each node by its name (the first 15 characters).
"""

from __future__ import annotations

import contextlib
import ctypes
import gc
import importlib
import json
import logging
import os
import re
import runpy
import select
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from typing import IO, Any

__all__ = ["PRELOAD", "ROS1_PRELOAD", "ROS2_PRELOAD", "ForkedNode", "Zygote"]

log = logging.getLogger(__name__)

_COMMON = (
    "asyncio",
    "click",
    "pydantic",
    "yaml",
    "cyborg.cli",
    "cyborg.cli.ros",
    "cyborg.run.node",
    "cyborg.run.launched",
    "cyborg.run.middleware",
    "cyborg.app.parts",
    "cyborg.app.registry",
    "importlib.metadata",  # the entry points, which every node but a thin one reads (cyborg.app.registry)
    "cyborg.app.sketch",
    "cyborg.app.config",  # the whole configuration's models: the controller, API, recorder, navigation, base
    "cyborg.configfile",
    "cyborg.modules",
    "cyborg.modules.gatekeeper",
    "cyborg.modules.placeholder",
    "cyborg.modules.idle",
    "cyborg.modules.music",
    "cyborg.modules.conversation",
    "cyborg.modules.speech",
)
ROS1_PRELOAD = (
    "rospy",
    "actionlib",
    "cyborg_controller.msg",
    "std_msgs.msg",
    "cyborg.transport.ros",
    *_COMMON,
    # what every rospy node imports as it joins the graph (its logging set-up, its address)
    "configparser",
    "logging.config",
    "logging.handlers",
    "netifaces",
    "encodings.idna",
    "stringprep",
    "rosgraph.roslogging",
    "cyborg.transport.ros.connections",
    "cyborg.transport.ros.writes",
    "cyborg.run.datadir",
    # what two or more of the bigger nodes import: the base, navigation, API and recorder speak
    # geometry and move_base messages; the controller, API and recorder build the robot's view,
    # its map and its stores
    "geometry_msgs.msg",
    "move_base_msgs.msg",
    "std_srvs.srv",
    "sqlite3",
    "cyborg.maps",
    "cyborg.app.view",
    "cyborg.app.robot",
    "cyborg.controller.runtime",
    "cyborg.emotion.system",
    "cyborg.motivator.component",
    "cyborg.observe.records",
)
"""What every ROS 1 node imports (the thin modules' kinds too: most nodes are thin), and what
several of the bigger ones do (a module two nodes import is held once instead of twice)."""
ROS2_PRELOAD = ("rclpy", "rclpy.action", "cyborg_controller.msg", "cyborg.transport.ros2", *_COMMON)
"""The same for ROS 2 (rclpy is imported, not initialised: no DDS participant before the fork)."""
FRESH = "fresh"
"""The slim zygote's mode: nothing preloaded, each node started afresh (exec)."""
PRELOAD = {"ros1": ROS1_PRELOAD, "ros2": ROS2_PRELOAD, FRESH: ()}
START_TIMEOUT = 60.0  # seconds the zygote may take to import and answer its first request


class ForkedNode:
    """One node forked by the zygote, used as the launch uses a :class:`subprocess.Popen`."""

    def __init__(self, pid: int, zygote: Zygote) -> None:
        self.pid = pid
        self.returncode: int | None = None
        self._zygote = zygote
        self._ended = threading.Event()

    def _exited(self, code: int) -> None:
        self.returncode = code
        self._ended.set()

    def poll(self) -> int | None:
        if self.returncode is None and not self._zygote.alive and not _exists(self.pid):
            self._exited(-1)  # the zygote is gone: no one can tell its exit code any more
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                raise subprocess.TimeoutExpired(f"node {self.pid}", timeout or 0.0)
            self._ended.wait(0.1 if left is None else min(left, 0.1))
        assert self.returncode is not None
        return self.returncode

    def send_signal(self, sig: int) -> None:
        if self.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, sig)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


def _exists(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class Zygote:
    """The launch's side of a zygote process: start it, have it fork nodes, hear their exits."""

    def __init__(self, python: str, env: dict[str, str] | None, preload: str, *, echo: bool) -> None:
        """``preload``: ``ros1`` or ``ros2`` (:data:`PRELOAD`)."""
        read_fd, write_fd = os.pipe()
        self._process = subprocess.Popen(
            [python, "-m", "cyborg.run.zygote", str(write_fd), preload],
            stdin=subprocess.PIPE,
            stdout=None if echo else subprocess.DEVNULL,
            env=env,
            pass_fds=(write_fd,),
        )
        os.close(write_fd)
        self._control: IO[str] = os.fdopen(read_fd, "r", encoding="utf-8")
        self._nodes: dict[int, ForkedNode] = {}
        self._forked: list[int] = []
        self._answer = threading.Condition()
        self._lock = threading.Lock()
        self.ended = threading.Event()
        """Set when a node ends (or the zygote does): the launch waits on it instead of polling."""
        self._reader = threading.Thread(target=self._read, name="zygote control", daemon=True)
        self._reader.start()

    @property
    def alive(self) -> bool:
        return self._process.poll() is None

    def spawn(self, argv: Sequence[str], *, module: str = "cyborg.cli") -> ForkedNode:
        """Fork a node running ``python -m MODULE`` with ``argv`` (for ``cyborg.cli``: what follows
        ``cyborg``; a launch's thin parts run ``cyborg.run.launched``)."""
        with self._lock:
            assert self._process.stdin is not None
            try:
                request = {"argv": list(argv), "module": module}
                self._process.stdin.write(json.dumps(request).encode() + b"\n")
                self._process.stdin.flush()
            except (BrokenPipeError, ValueError) as exc:
                raise OSError(f"the zygote process ended (exit code {self._process.poll()})") from exc
            deadline = time.monotonic() + START_TIMEOUT
            with self._answer:
                while not self._forked:
                    if not self.alive or time.monotonic() > deadline:
                        raise OSError(f"the zygote process did not fork (exit code {self._process.poll()})")
                    self._answer.wait(0.1)
                pid = self._forked.pop(0)
                node = self._nodes.setdefault(pid, ForkedNode(pid, self))
            return node

    def slim(self) -> None:
        """Have the zygote drop its preloaded modules: nodes it starts from now on start afresh."""
        with self._lock:
            assert self._process.stdin is not None
            with contextlib.suppress(BrokenPipeError, ValueError):
                self._process.stdin.write(json.dumps({"slim": True}).encode() + b"\n")
                self._process.stdin.flush()

    def _read(self) -> None:
        for line in self._control:
            try:
                message: dict[str, Any] = json.loads(line)
            except ValueError:
                continue
            with self._answer:
                if "forked" in message:
                    self._forked.append(int(message["forked"]))
                    self._answer.notify_all()
                elif "exited" in message:
                    pid = int(message["exited"])
                    node = self._nodes.setdefault(pid, ForkedNode(pid, self))
                    node._exited(int(message["code"]))
                    self.ended.set()
        self.ended.set()  # the zygote is gone

    def close(self, *, at_once: bool = False) -> None:
        """End the zygote (its nodes are stopped already); ``at_once``: kill it (it forked none)."""
        if self._process.stdin is not None:
            with contextlib.suppress(OSError):
                self._process.stdin.close()
        try:
            self._process.wait(timeout=0 if at_once else 5)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait(timeout=5)
        self._reader.join(timeout=2)
        self._control.close()


# --- the zygote process -------------------------------------------------------------------------


def _serve(control: IO[str], preload: Sequence[str], pending: bytes = b"") -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the nodes stop on Ctrl-C; the zygote on end of stdin
    fresh = not preload
    for name in preload:
        try:
            importlib.import_module(name)
        except Exception as exc:  # a missing piece only costs its node the import
            print(f"zygote: could not preload {name}: {exc}", file=sys.stderr, flush=True)
    if preload is ROS1_PRELOAD:
        _find_ros_log_config()
    _fork_safely()
    gc.collect()
    gc.freeze()  # what the nodes inherit stays out of their collections: its pages stay shared
    wake_read, wake_write = os.pipe()
    os.set_blocking(wake_write, False)
    signal.set_wakeup_fd(wake_write)
    signal.signal(signal.SIGCHLD, lambda *_: None)
    stdin = sys.stdin.buffer
    while True:
        _reap(control)  # (first: children that ended before this program began, when slim)
        while b"\n" in pending:
            line, pending = pending.split(b"\n", 1)
            request = json.loads(line)
            if request.get("slim"):
                if not fresh:
                    control.flush()
                    os.execv(
                        sys.executable,
                        [
                            sys.executable,
                            "-m",
                            "cyborg.run.zygote",
                            str(control.fileno()),
                            FRESH,
                            pending.decode(),
                        ],
                    )
                continue
            pid = os.fork()
            if pid == 0:
                os.close(wake_read)
                os.close(wake_write)
                _child(request["argv"], control, fresh=fresh, module=request.get("module", "cyborg.cli"))
            control.write(json.dumps({"forked": pid}) + "\n")
            control.flush()
        ready, _, _ = select.select([stdin, wake_read], [], [])
        if wake_read in ready:
            os.read(wake_read, 512)
        if stdin in ready:
            chunk = os.read(stdin.fileno(), 65536)
            if not chunk:
                return
            pending += chunk


_LTTNG_UST = re.compile(r"/liblttng-ust(-[0-9a-f]+)?\.so[.0-9]*$")
_SIGSET_BYTES = 128  # sizeof(sigset_t) on Linux


def _fork_safely() -> None:
    """Fork as LTTng-UST asks of a process it traces, when the imports loaded it.

    ROS 2's wheels (rcl's and rmw's tracepoints) load liblttng-ust, whose constructor starts two
    listener threads: the zygote is not single-threaded below Python. LTTng-UST's fork protocol
    (what its ``liblttng-ust-fork.so`` wraps ``fork()`` with) takes its locks before the fork, so
    that no thread holds them in the copy, and in the child resets its state and starts its
    listeners again, as in a freshly started process.
    """
    path = next(
        (line.split()[-1] for line in _maps() if _LTTNG_UST.search(line.split()[-1])),
        None,
    )
    if path is None:
        return
    lib = ctypes.CDLL(path)
    prefix = "lttng_ust_" if hasattr(lib, "lttng_ust_before_fork") else "ust_"  # 2.13 / 2.12
    before, parent, child = (
        getattr(lib, f"{prefix}{step}") for step in ("before_fork", "after_fork_parent", "after_fork_child")
    )
    saved = ctypes.create_string_buffer(_SIGSET_BYTES)  # the signal mask, blocked meanwhile
    os.register_at_fork(
        before=lambda: before(saved),
        after_in_parent=lambda: parent(saved),
        after_in_child=lambda: child(saved),
    )


def _maps() -> list[str]:
    with open(f"/proc/{os.getpid()}/maps", encoding="utf-8", errors="replace") as maps:
        return [line for line in maps if "/" in line]


def _find_ros_log_config() -> None:
    """Find rospy's logging configuration once, as each node would at ``init_node``, and hand it
    to them all (``ROS_PYTHON_LOG_CONFIG_FILE``, unless it is set): rospy looks for it in
    ``$ROS_HOME/config``, ``/etc/ros`` and the ``rosgraph`` package, which it finds by crawling
    ``ROS_PACKAGE_PATH``, in every node (a third of a megabyte of each forked node's own memory)."""
    if os.environ.get("ROS_PYTHON_LOG_CONFIG_FILE"):
        return
    try:
        import rospkg  # type: ignore[import-not-found]

        folders = [os.path.join(rospkg.get_ros_home(), "config"), rospkg.get_etc_ros_dir()]
        with contextlib.suppress(rospkg.common.ResourceNotFound):
            folders.append(os.path.join(rospkg.RosPack().get_path("rosgraph"), "conf"))
    except Exception:  # no rospkg, or a broken one: each node looks for itself
        return
    for folder in folders:
        for extension in ("conf", "yaml"):
            path = os.path.join(folder, f"python_logging.{extension}")
            if os.path.isfile(path):
                os.environ["ROS_PYTHON_LOG_CONFIG_FILE"] = path
                return


def _reap(control: IO[str]) -> None:
    while True:
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return
        control.write(json.dumps({"exited": pid, "code": os.waitstatus_to_exitcode(status)}) + "\n")
        control.flush()


def _child(argv: list[str], control: IO[str], *, fresh: bool = False, module: str = "cyborg.cli") -> None:
    """In the forked child: become ``python -m MODULE ARGV`` (``fresh``: a new one, exec'd).
    Never returns: the command ends with SystemExit, which ends this process as it ends a
    freshly started one (atexit, threads)."""
    signal.set_wakeup_fd(-1)
    signal.signal(signal.SIGCHLD, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    control.close()
    _name_process(argv[1] if len(argv) > 1 and argv[0] == "node" else "cyborg")
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    os.close(devnull)
    if fresh:
        os.execv(sys.executable, [sys.executable, "-m", module, *argv])
    sys.argv = ["cyborg", *argv]
    preloaded = sys.modules.get(module)
    if preloaded is not None and not hasattr(preloaded, "__path__"):
        # runpy would run a second copy of it as __main__ beside the one loaded (and warn)
        preloaded.main()
    else:
        runpy.run_module(module, run_name="__main__", alter_sys=True)  # as `python -m MODULE` does
    raise SystemExit(0)


def _name_process(name: str) -> None:
    """Set the command's name (``ps -e``, ``top``; Linux keeps 15 characters)."""
    with contextlib.suppress(OSError), open(f"/proc/{os.getpid()}/comm", "w", encoding="ascii") as comm:
        comm.write(name.encode("ascii", errors="replace").decode()[:15])


def main() -> None:
    control_fd, preload, *pending = sys.argv[1:]
    control = os.fdopen(int(control_fd), "w", encoding="utf-8")
    _serve(control, PRELOAD[preload], "".join(pending).encode())


if __name__ == "__main__":
    main()
