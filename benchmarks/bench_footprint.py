"""Footprint of the robot's processes, beside bare rospy and rclpy nodes measured in the same run.

Memory is read from /proc/PID/smaps_rollup: RSS, PSS (shared pages split among the processes that
map them) and USS (private pages: what one more such process costs). Every figure is the median of
``--runs`` runs (min-max); each node's is also given as a ratio to its floor's median, same run.

* help, say: ``cyborg --help``, and ``cyborg say hello`` against a running embedded ``cyborg sim``:
  wall time of the whole command. Measured first, while this process is quiet (it never joins a
  ROS graph itself: a rospy process whose master is gone spins its XML-RPC thread).
* sim: embedded ``cyborg sim`` (default config, real time), a fresh one each run: peak RSS
  (VmHWM) over ``--sim-seconds`` and RSS at the end.
* floor / node (ROS 1): a bare rospy node serving one ``actionlib.SimpleActionServer``, and
  ``cyborg node cyborg_joke`` of demo.yaml (a placeholder module) started as ``cyborg launch``
  starts it (``python -m cyborg.run.launched node ... --checked``: the launch validated the file,
  no click; the command of :meth:`cyborg.run.supervisor.Launch.command`) and by hand (``cyborg
  node``: it validates the file itself), alternating; memory 1 s after each says it is ready.
* floor2 / node2 (ROS 2): the same with a bare rclpy node serving one ``ActionServer``, and
  ``cyborg node --ros2`` in the ROS 2 venv's Python.
* Both beside a companion floor node that runs throughout (a robot has many nodes): the
  middleware's libraries are shared then, whatever else runs on the machine.
* launch / launch2: ``cyborg launch`` (ROS 1 against a roscore this benchmark starts; ROS 2 with
  ``--ros2`` on a domain of its own) of the default configuration: wall time from its start until
  the controller's first message on ``/cyborg_controller/state_change`` (heard by a watcher
  process), CPU of the launch's processes until then, PSS / USS / RSS of all of them (launcher and
  nodes; ROS 1's rosmaster and rosout apart) 5 s later, then their CPU over ``--idle-seconds``
  (ROS 1: and the master's) as a percentage of one core. The robot of the default configuration
  starts wandering about 12 s in: that figure is a robot that is up and moving slowly. At rest:
  the CPU from 2 s after the first state (idle) until the next state change (the robot in its idle
  state, the base still, nobody talking; about 10 s); ``--still`` launches the packaged robot
  without the motivator's events of the idle state, so it stays at rest for the whole window.

The load average (1 min) is printed with each figure. The processes run with ``PYTHONPATH=--src``
first when given (a checkout's ``src`` folder, to measure an older commit beside the working
tree; ROS 2 processes run the code the ROS 2 venv imports, or ``$CYBORG_ROS2_PYTHON``'s). The
benchmark starts its own roscore on a free port with a temporary ROS_HOME, uses a random
ROS_DOMAIN_ID, and stops everything it started (process groups).

Run: .venv/bin/python benchmarks/bench_footprint.py [--runs 3] [--sim-seconds 30] [--idle-seconds 20]
     [--src DIR] [--only help,say,sim,node,node2,launch,launch2] [--still | --config FILE]
"""

from __future__ import annotations

import argparse
import contextlib
import os
import random
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from _machine import machine_line

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "src" / "cyborg" / "data"
STATE_CHANGE = "/cyborg_controller/state_change"
SETTLE = 1.0  # seconds between "ready" and reading the memory
AFTER_FIRST_STATE = 5.0  # seconds between the launch's first state and reading its memory
REST_SETTLE = 2.0  # seconds after the first state before the CPU at rest is read
SAMPLE = 0.25  # seconds between readings of the launch's CPU
MB = 1024 * 1024
TARGETS = {  # issue 33 (node, launch) and issue 13 (say, sim)
    "node_uss_ratio": 1.15,
    "launch_s": 3.0,
    "launch_pss_mib": 300.0,
    "idle_pct": 2.0,
    "say_s": 0.3,
    "sim_peak_mb": 150.0,
}
ISSUE_BEFORE = (
    "issue 33 (before, load 2-3): node 1.39x the rospy floor by USS; launch: first state 6.7 s, "
    "PSS 645 MiB, idle 5.9 % + rosmaster 1.65 % of a core"
)


# --- the floors' and watchers' own processes -------------------------------------------------------


def role_floor() -> None:
    """A bare rospy node serving one action: what any Python ROS 1 node must hold."""
    import actionlib  # type: ignore[import-not-found]
    import rospy  # type: ignore[import-not-found]
    from cyborg_controller.msg import StateMachineAction  # type: ignore[import-not-found]

    rospy.init_node("bench_floor", disable_signals=True)

    def execute(goal: Any) -> None:
        server.set_succeeded()

    server = actionlib.SimpleActionServer("/bench_floor/serve", StateMachineAction, execute, auto_start=False)
    server.start()
    print("floor serving", file=sys.stderr, flush=True)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    stop.wait()
    rospy.signal_shutdown("benchmark done")


def role_floor2() -> None:
    """A bare rclpy node serving one action: what any Python ROS 2 node must hold."""
    import rclpy  # type: ignore[import-not-found]
    from cyborg_controller.action import StateMachine  # type: ignore[import-not-found]
    from rclpy.action import ActionServer  # type: ignore[import-not-found]
    from rclpy.executors import SingleThreadedExecutor  # type: ignore[import-not-found]
    from rclpy.node import Node  # type: ignore[import-not-found]

    rclpy.init()
    node = Node("bench_floor")

    def execute(handle: Any) -> Any:
        handle.succeed()
        return StateMachine.Result()

    server = ActionServer(node, StateMachine, "/bench_floor/serve", execute)  # noqa: F841 (kept)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    threading.Thread(target=executor.spin, daemon=True).start()
    print("floor serving", file=sys.stderr, flush=True)
    stop.wait()
    executor.shutdown(timeout_sec=1)


def role_watch() -> None:
    """Print the Unix time and the new state of each message on STATE_CHANGE (ROS 1)."""
    import rospy
    from cyborg_controller.msg import SystemState  # type: ignore[import-not-found]

    rospy.init_node("bench_watch", anonymous=True, disable_signals=True)
    heard = threading.Event()

    def on_change(message: Any) -> None:
        heard.set()
        print(f"state {time.time()!r} {message.to_system_state}", flush=True)

    rospy.Subscriber(STATE_CHANGE, SystemState, on_change, queue_size=10)
    print("watching", flush=True)
    heard.wait()
    time.sleep(3600)


def role_watch2() -> None:
    """Print the Unix time and the new state of each message on STATE_CHANGE (ROS 2, latched)."""
    import rclpy
    from cyborg_controller.msg import SystemState
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy  # type: ignore[import-not-found]

    rclpy.init()
    node = Node(f"bench_watch_{os.getpid()}")
    heard = threading.Event()

    def on_change(message: Any) -> None:
        heard.set()
        print(f"state {time.time()!r} {message.to_system_state}", flush=True)

    latched = QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )
    node.create_subscription(SystemState, STATE_CHANGE, on_change, latched)
    print("watching", flush=True)
    rclpy.spin(node)


# --- processes ------------------------------------------------------------------------------------


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def proc_kb(pid: int, field: str) -> int | None:
    """``VmRSS`` or ``VmHWM`` of ``pid`` in kB (None when it is gone)."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as status:
            for line in status:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except (OSError, ValueError):
        return None
    return None


def rss_mb(pid: int, field: str = "VmRSS") -> float:
    kb = proc_kb(pid, field)
    if kb is None:
        raise SystemExit(f"process {pid} is gone before its {field} was read")
    return kb / 1024


def children_of(pid: int) -> list[int]:
    """Direct children of ``pid`` (from /proc/*/stat)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rfind(")") + 2 :].split()
        if int(fields[1]) == pid:
            found.append(int(entry.name))
    return found


def node_name(pid: int) -> str:
    try:
        args = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return "?"
    words = [a.decode() for a in args]
    if "node" in words:
        return words[words.index("node") + 1]
    with contextlib.suppress(OSError):  # forked by the launch's zygote: named by its command's name
        if "cyborg.run.zygote" in words:
            return Path(f"/proc/{pid}/comm").read_text().strip()
    return " ".join(words[:3])


def stop_group(process: subprocess.Popen[Any] | None, grace: float = 10.0) -> None:
    """Stop a child we started (it leads its own process group) and whatever it started."""
    if process is None:
        return
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGINT)
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.wait(grace)
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(process.pid, signal.SIGKILL)
    with contextlib.suppress(subprocess.TimeoutExpired):
        process.wait(5)


class Child:
    """A child in its own process group, its output in a log file; ready once a line appears."""

    def __init__(self, command: Sequence[str], env: dict[str, str], log_dir: Path, name: str) -> None:
        self.log_path = log_dir / f"{name}-{time.monotonic_ns()}.log"
        self.name = name
        self.started = time.perf_counter()
        with self.log_path.open("wb") as log:
            self.process = subprocess.Popen(
                list(command),
                env={**env, "PYTHONUNBUFFERED": "1"},
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )

    @property
    def pid(self) -> int:
        return self.process.pid

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def wait_line(self, line: str, timeout: float = 120.0) -> float:
        """Seconds from the start until ``line`` is in the output."""
        deadline = time.monotonic() + timeout
        while line not in self.log():
            if self.process.poll() is not None:
                raise SystemExit(
                    f"{self.name} exited ({self.process.returncode}); its log:\n{self.log()[-3000:]}"
                )
            if time.monotonic() > deadline:
                raise SystemExit(f"{self.name}: no {line!r} within {timeout} s; log:\n{self.log()[-3000:]}")
            time.sleep(0.02)
        return time.perf_counter() - self.started

    def stop(self) -> None:
        stop_group(self.process)


@contextlib.contextmanager
def ros_graph(env: dict[str, str]) -> Iterator[dict[str, str]]:
    """A roscore on a free port with a temporary ROS_HOME; yields the environment of its nodes."""
    port = free_port()
    ros_home = Path(tempfile.mkdtemp(prefix="cyborg-bench-ros-"))
    env = {
        **env,
        "ROS_MASTER_URI": f"http://localhost:{port}",
        "ROS_HOSTNAME": "localhost",
        "ROS_HOME": str(ros_home),
    }
    env.pop("ROS_IP", None)
    core = None
    try:
        core = subprocess.Popen(
            ["roscore", "-p", str(port)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        ROS_CORE.append(core)
        import xmlrpc.client

        master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
        deadline = time.monotonic() + 30
        while True:
            try:
                answer: Any = master.lookupNode("/bench", "/rosout")
                if answer[0] == 1:
                    break
            except (OSError, xmlrpc.client.Fault):
                pass
            if core.poll() is not None or time.monotonic() > deadline:
                raise SystemExit("roscore did not start; fix: scripts/install-ros")
            time.sleep(0.05)
        yield env
    finally:
        stop_group(core)
        shutil.rmtree(ros_home, ignore_errors=True)


# --- the measurements -----------------------------------------------------------------------------


def load() -> float:
    return os.getloadavg()[0]


def memory(pid: int) -> dict[str, float]:
    """RSS, PSS and USS of ``pid`` in MiB (from smaps_rollup)."""
    fields: dict[str, int] = {}
    try:
        with open(f"/proc/{pid}/smaps_rollup", encoding="ascii") as rollup:
            for line in rollup:
                parts = line.split()
                if len(parts) >= 2 and parts[1].isdigit():
                    fields[parts[0].rstrip(":")] = int(parts[1])
    except OSError:
        raise SystemExit(f"process {pid} is gone before its memory was read") from None
    return {
        "rss": fields["Rss"] / 1024,
        "pss": fields["Pss"] / 1024,
        "uss": (fields["Private_Clean"] + fields["Private_Dirty"]) / 1024,
    }


def cpu_seconds(pid: int) -> float:
    """utime + stime of ``pid`` (0 when it is gone)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return 0.0
    fields = stat[stat.rfind(")") + 2 :].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def descendants(pid: int) -> list[int]:
    found, todo = [], [pid]
    while todo:
        children = children_of(todo.pop())
        found += children
        todo += children
    return found


def cyborg(*args: str, python: str | None = None) -> list[str]:
    """The ``cyborg`` console script's import path (``from cyborg.cli import main``)."""
    return [
        python or sys.executable,
        "-c",
        "import sys; from cyborg.cli import main; sys.exit(main())",
        *args,
    ]


def ros2_python() -> str:
    from cyborg.run.ros2_env import ros2_python as find

    return find()


def ros2_env(env: dict[str, str], log_dir: Path) -> dict[str, str]:
    """The environment of the ROS 2 processes: the ROS 2 venv's (no ROS 1 PYTHONPATH), a domain of
    their own, discovery on this host."""
    from cyborg.run.ros2_env import ros2_environment

    saved = dict(os.environ)
    os.environ.clear()
    os.environ.update(env)
    try:
        ros2 = ros2_environment()
    finally:
        os.environ.clear()
        os.environ.update(saved)
    ros2["ROS_DOMAIN_ID"] = str(random.randint(1, 200))
    ros2["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    ros2["ROS_LOG_DIR"] = str(log_dir / "ros2-log")
    return ros2


def checked(config: Path) -> list[str]:
    from cyborg.app.sketch import text_digest

    return ["--checked", text_digest(config.read_text(encoding="utf-8"))]


def measure_floor(env: dict[str, str], log_dir: Path, *, ros2: bool) -> dict[str, float]:
    python = ros2_python() if ros2 else sys.executable
    role = "floor2" if ros2 else "floor"
    child = Child([python, __file__, "--role", role], env, log_dir, role)
    try:
        child.wait_line("floor serving")
        time.sleep(SETTLE)
        return memory(child.pid)
    finally:
        child.stop()


def measure_node(
    env: dict[str, str], log_dir: Path, name: str, config: Path, *, launched: bool, ros2: bool
) -> dict[str, float]:
    data = Path(tempfile.mkdtemp(prefix="cyborg-bench-db-", dir=log_dir))
    args = ["node", name, "--config", str(config), "--db", str(data)]
    args += checked(config) if launched else []
    args += ["--ros2"] if ros2 else []
    python = ros2_python() if ros2 else sys.executable
    command = cyborg(*args, python=python)
    if launched and LAUNCHED_ENTRY:  # (an older checkout launched its nodes as `cyborg node`)
        command = [python, "-m", "cyborg.run.launched", *args]
    child = Child(command, env, log_dir, name)
    try:
        child.wait_line(f"node {name} running")
        time.sleep(SETTLE)
        return memory(child.pid)
    finally:
        child.stop()


def states_heard(watcher: Child) -> list[tuple[float, str]]:
    """(Unix time, new state) of each state change the watcher has heard so far."""
    heard = []
    for line in watcher.log().splitlines():
        words = line.split()
        if len(words) >= 2 and words[0] == "state":
            heard.append((float(words[1]), words[2] if len(words) > 2 else "?"))
    return heard


def measure_launch(
    env: dict[str, str],
    log_dir: Path,
    *,
    ros2: bool,
    master_pids: Sequence[int],
    idle_seconds: float,
    launch_env: dict[str, str] | None = None,
) -> dict[str, Any]:
    """Seconds to the first state; CPU until then; memory 5 s later; CPU at rest and over
    ``idle_seconds``.

    At rest: from ``REST_SETTLE`` s after the first state until the next state change (the robot
    in its first state, the base still, nobody talking), at most ``AFTER_FIRST_STATE +
    idle_seconds``; CPU is sampled every ``SAMPLE`` s and the last sample before the change ends
    the window. Then, as before, CPU over ``idle_seconds`` from ``AFTER_FIRST_STATE`` s after the
    first state, whatever the robot does (the packaged robot wanders).
    """
    data = Path(tempfile.mkdtemp(prefix="cyborg-bench-db-", dir=log_dir))
    python = ros2_python() if ros2 else sys.executable
    watcher = Child([python, __file__, "--role", "watch2" if ros2 else "watch"], env, log_dir, "watch")
    launch = None
    try:
        watcher.wait_line("watching")
        began = time.time()
        args = ["launch", "--db", str(data), "--port", str(free_port())] + (["--ros2"] if ros2 else [])
        args += ["--config", str(LAUNCH_CONFIG[0])] if LAUNCH_CONFIG else []
        launch = Child(cyborg(*args), launch_env or env, log_dir, "launch")
        deadline = time.monotonic() + 120
        while not states_heard(watcher):
            if launch.process.poll() is not None or time.monotonic() > deadline:
                raise SystemExit(f"no state change within 120 s; launch log:\n{launch.log()[-3000:]}")
            time.sleep(0.02)
        first_at = states_heard(watcher)[0][0]
        first = first_at - began
        pids = [launch.pid, *descendants(launch.pid)]
        cpu_first = sum(cpu_seconds(pid) for pid in pids)
        load_first = load()
        watched = pids + list(master_pids)
        samples: list[tuple[float, dict[int, float]]] = []  # (Unix time, CPU seconds of each pid)
        mems: dict[int, dict[str, float]] = {}
        names: dict[int, str] = {}
        master_mem: list[dict[str, float]] = []
        idle_from: dict[int, float] = {}
        idle_began = 0.0
        end = first_at + AFTER_FIRST_STATE + idle_seconds
        while (now := time.time()) < end:
            if now >= first_at + REST_SETTLE:
                samples.append((now, {pid: cpu_seconds(pid) for pid in watched}))
            if not mems and now >= first_at + AFTER_FIRST_STATE:
                pids = [launch.pid, *descendants(launch.pid)]
                mems = {pid: memory(pid) for pid in pids}
                names = {pid: node_name(pid) for pid in pids}
                names[launch.pid] = "(launcher)"
                master_mem = [memory(pid) for pid in master_pids]
                watched = pids + list(master_pids)
                idle_from = {pid: cpu_seconds(pid) for pid in watched}
                idle_began = time.time()
            time.sleep(SAMPLE)
        used = {pid: cpu_seconds(pid) - idle_from[pid] for pid in watched}
        idle_span = time.time() - idle_began
        heard = states_heard(watcher)
        changes = [t for t, _ in heard[1:]]
        rest_end = changes[0] if changes else end
        rest = [x for x in samples if x[0] <= rest_end]
        rest_s = rest[-1][0] - rest[0][0] if len(rest) >= 2 else 0.0
        rest_used = (
            {pid: rest[-1][1].get(pid, 0.0) - rest[0][1].get(pid, 0.0) for pid in watched} if rest_s else {}
        )

        def pct(used: dict[int, float], among: Sequence[int], span: float) -> float | None:
            return 100 * sum(used.get(pid, 0.0) for pid in among) / span if span > 0 else None

        return {
            "first": first,
            "load": load_first,
            "cpu_first": cpu_first,
            "processes": len(pids),
            "pss": sum(m["pss"] for m in mems.values()),
            "uss": sum(m["uss"] for m in mems.values()),
            "rss": sum(m["rss"] for m in mems.values()),
            "launcher_pss": mems[launch.pid]["pss"],
            "master_pss": sum(m["pss"] for m in master_mem),
            "per_node_pss": {names[pid]: m["pss"] for pid, m in mems.items()},
            "idle_pct": pct(used, pids, idle_span),
            "master_idle_pct": pct(used, master_pids, idle_span),
            "per_node_idle": {names[pid]: 100 * used[pid] / idle_span for pid in pids},
            "idle_changes": sum(1 for t in changes if idle_began <= t <= idle_began + idle_span),
            "rest_s": rest_s,
            "rest_state": heard[0][1],
            "rest_pct": pct(rest_used, pids, rest_s),
            "master_rest_pct": pct(rest_used, master_pids, rest_s),
            "per_node_rest": {
                names.get(pid, str(pid)): 100 * rest_used.get(pid, 0.0) / rest_s for pid in pids
            }
            if rest_s
            else {},
            "load_end": load(),
        }
    finally:
        if launch is not None:
            launch.stop()
        watcher.stop()


def wall(command: Sequence[str], env: dict[str, str]) -> float:
    started = time.perf_counter()
    result = subprocess.run(list(command), env=env, capture_output=True, check=False)
    took = time.perf_counter() - started
    if result.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed: {result.stderr.decode(errors='replace')[-2000:]}")
    return took


def start_sim(env: dict[str, str], log_dir: Path) -> tuple[Child, str]:
    data = Path(tempfile.mkdtemp(prefix="cyborg-bench-db-", dir=log_dir))
    port = free_port()
    child = Child(cyborg("sim", "--port", str(port), "--db", str(data)), env, log_dir, "sim")
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 120
    while True:
        with contextlib.suppress(OSError), urllib.request.urlopen(url + "/api/status", timeout=2):
            break
        if child.process.poll() is not None or time.monotonic() > deadline:
            child.stop()
            raise SystemExit(f"cyborg sim did not serve {url}; its log:\n{child.log()[-3000:]}")
        time.sleep(0.1)
    return child, url


def median(values: list[float]) -> float:
    return statistics.median(values)


def spread(values: list[float], fmt: str) -> str:
    return f"{format(median(values), fmt)} ({format(min(values), fmt)}-{format(max(values), fmt)})"


def loads(values: list[float]) -> str:
    return f"{min(values):.1f}-{max(values):.1f}"


def bench_nodes(env: dict[str, str], log_dir: Path, runs: int, *, ros2: bool) -> dict[str, Any]:
    """The floor and the placeholder node (as launched, and by hand), alternating, beside a
    companion floor node that runs throughout: the middleware's libraries are then shared, as on
    a robot of many nodes, whatever else runs on the machine (alone, a process's clean library
    pages count as its own: a ROS 2 floor's USS read 37 or 59 MiB as other ROS 2 processes came
    and went)."""
    config = DATA / "demo.yaml"
    out: dict[str, Any] = {"floor": [], "launched": [], "by_hand": [], "load": []}
    python = ros2_python() if ros2 else sys.executable
    companion = Child([python, __file__, "--role", "floor2" if ros2 else "floor"], env, log_dir, "companion")
    try:
        companion.wait_line("floor serving")
        for run in range(runs):
            order = ["floor", "launched", "by_hand"]
            for kind in order if run % 2 == 0 else order[::-1]:  # load changes hit all alike
                out["load"].append(load())
                if kind == "floor":
                    out["floor"].append(measure_floor(env, log_dir, ros2=ros2))
                else:
                    launched = kind == "launched"
                    out[kind].append(
                        measure_node(env, log_dir, "cyborg_joke", config, launched=launched, ros2=ros2)
                    )
    finally:
        companion.stop()
    return out


def attempts(measure: Callable[[], dict[str, Any]], runs: int, what: str) -> list[dict[str, Any]]:
    """``runs`` measurements; one that fails is told on stderr and left out (the others stand)."""
    done = []
    for run in range(runs):
        try:
            done.append(measure())
        except SystemExit as exc:
            print(f"{what}, run {run + 1}: {exc}"[:3000], file=sys.stderr, flush=True)
    return done


def bench(
    parts: set[str], runs: int, sim_seconds: float, idle_seconds: float, src: Path | None
) -> dict[str, Any]:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src.resolve()) + (
            os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else ""
        )
    out: dict[str, Any] = {}
    log_dir = Path(tempfile.mkdtemp(prefix="cyborg-bench-footprint-"))
    try:
        if "help" in parts:  # first: this process is quiet, and nothing else of ours runs
            wall(cyborg("--help"), env)  # warm the file cache
            out["help_load"] = load()
            out["help"] = [wall(cyborg("--help"), env) for _ in range(max(5, runs))]
        if parts & {"say", "sim"}:
            peaks: list[float] = []
            settled: list[float] = []
            for run in range(runs if "sim" in parts else 1):  # a fresh sim each run
                sim, url = start_sim(env, log_dir)
                try:
                    if "say" in parts and run == 0:
                        say = cyborg("say", "hello", "--url", url)
                        wall(say, env)
                        out["say_load"] = load()
                        out["say"] = [wall(say, env) for _ in range(max(5, runs))]
                    if "sim" in parts:
                        remaining = sim_seconds - (time.perf_counter() - sim.started)
                        time.sleep(max(0.0, remaining))
                        peaks.append(rss_mb(sim.pid, "VmHWM"))
                        settled.append(rss_mb(sim.pid))
                        out.setdefault("sim_load", []).append(load())
                finally:
                    sim.stop()
            if peaks:
                out["sim_peak"] = peaks
                out["sim_rss"] = settled
        if parts & {"node", "launch"}:
            with ros_graph(env) as ros_env:
                if "node" in parts:
                    out["node"] = bench_nodes(ros_env, log_dir, runs, ros2=False)
                if "launch" in parts:
                    core = ROS_CORE[-1].pid
                    master = [core, *descendants(core)]  # roscore, rosmaster, rosout
                    out["launch"] = [
                        measure_launch(
                            ros_env, log_dir, ros2=False, master_pids=master, idle_seconds=idle_seconds
                        )
                        for _ in range(runs)
                    ]
        if parts & {"node2", "launch2"}:
            ros2 = ros2_env(env, log_dir)
            if "node2" in parts:
                out["node2"] = bench_nodes(ros2, log_dir, runs, ros2=True)
            if "launch2" in parts:  # the launcher in this venv; it starts its nodes in the ROS 2 one
                graph = ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR")
                launcher = {**env, **{key: ros2[key] for key in graph}}
                out["launch2"] = [
                    measure_launch(
                        ros2,
                        log_dir,
                        ros2=True,
                        master_pids=[],
                        idle_seconds=idle_seconds,
                        launch_env=launcher,
                    )
                    for _ in range(runs)
                ]
    finally:
        shutil.rmtree(log_dir, ignore_errors=True)
    return out


def report(out: dict[str, Any], runs: int, sim_seconds: float, idle_seconds: float, src: Path | None) -> None:
    print(f"machine: {machine_line()}")
    print(f"code: {src if src is not None else 'this working tree'}; medians of {runs} runs (min-max)")
    print(
        "launch configuration: "
        + (
            "the packaged robot without its idle state's motivator events (--still: at rest)"
            if LAUNCH_CONFIG and LAUNCH_CONFIG[0].name == "still.yaml"
            else str(LAUNCH_CONFIG[0])
            if LAUNCH_CONFIG
            else "the packaged robot (cyborg.yaml)"
        )
    )
    print(ISSUE_BEFORE)
    print("| what | figure | target | | load (1 min) |")
    print("|---|---:|---|---|---|")

    def row(what: str, figure: str, target: str = "", ok: bool | None = None, at: str = "") -> None:
        verdict = "" if ok is None else ("pass" if ok else "FAIL")
        print(f"| {what} | {figure} | {target} | {verdict} | {at} |")

    if "help" in out:
        row("cyborg --help, wall s", spread(out["help"], ".3f"), at=f"{out['help_load']:.1f}")
    if "say" in out:
        say = median(out["say"])
        row(
            "cyborg say hello (embedded sim), wall s",
            spread(out["say"], ".3f"),
            f"<= {TARGETS['say_s']}",
            say <= TARGETS["say_s"],
            f"{out['say_load']:.1f}",
        )
    if "sim_peak" in out:
        row(
            f"cyborg sim peak RSS (VmHWM) over {sim_seconds:g} s, MB",
            spread(out["sim_peak"], ".0f"),
            f"<= {TARGETS['sim_peak_mb']:g}",
            median(out["sim_peak"]) <= TARGETS["sim_peak_mb"],
            loads(out["sim_load"]),
        )
        row(f"cyborg sim RSS after {sim_seconds:g} s, MB", spread(out["sim_rss"], ".0f"))
    for key, middleware, floor_name in (("node", "ROS 1", "rospy"), ("node2", "ROS 2", "rclpy")):
        if key not in out:
            continue
        nodes = out[key]
        at = loads(nodes["load"])
        floor = {m: median([x[m] for x in nodes["floor"]]) for m in ("uss", "pss", "rss")}
        row(
            f"{middleware} floor: bare {floor_name} node + action server, USS / PSS / RSS MiB",
            " / ".join(spread([x[m] for x in nodes["floor"]], ".1f") for m in ("uss", "pss", "rss")),
            at=at,
        )
        for kind, label in (("launched", "as launched (--checked)"), ("by_hand", "by hand (validates)")):
            figures = {m: median([x[m] for x in nodes[kind]]) for m in ("uss", "pss", "rss")}
            ratios = {m: figures[m] / floor[m] for m in figures}
            row(
                f"{middleware} cyborg node cyborg_joke (demo.yaml placeholder) {label}, USS / PSS / RSS MiB",
                " / ".join(spread([x[m] for x in nodes[kind]], ".1f") for m in ("uss", "pss", "rss")),
                at=at,
            )
            row(
                "  ratio to the floor, USS / PSS / RSS",
                f"**{ratios['uss']:.2f}** / {ratios['pss']:.2f} / {ratios['rss']:.2f}",
                f"USS <= {TARGETS['node_uss_ratio']}" if kind == "launched" else "",
                ratios["uss"] <= TARGETS["node_uss_ratio"] if kind == "launched" else None,
                at,
            )
    for key, middleware in (("launch", "ROS 1"), ("launch2", "ROS 2")):
        if not out.get(key):
            continue
        launches = out[key]
        at = loads([x["load"] for x in launches])

        def figure(name: str, fmt: str, launches: list[dict[str, Any]] = launches) -> str:
            return spread([x[name] for x in launches], fmt)

        first = median([x["first"] for x in launches])
        row(
            f"{middleware} cyborg launch: first state, s ({len(launches)} of {runs} runs)",
            figure("first", ".2f"),
            f"<= {TARGETS['launch_s']:g}",
            first <= TARGETS["launch_s"],
            at,
        )
        row(
            f"  CPU of its processes until then, s ({launches[0]['processes']} processes)",
            figure("cpu_first", ".2f"),
            at=at,
        )
        pss = median([x["pss"] for x in launches])
        row(
            f"  PSS of the launcher and its nodes {AFTER_FIRST_STATE:g} s later, MiB",
            figure("pss", ".0f"),
            f"<= {TARGETS['launch_pss_mib']:g}",
            pss <= TARGETS["launch_pss_mib"],
            at,
        )
        row("  USS / RSS of the same, MiB", f"{figure('uss', '.0f')} / {figure('rss', '.0f')}", at=at)
        row("  of it the launcher, PSS MiB", figure("launcher_pss", ".0f"), at=at)
        per = launches[-1]["per_node_pss"]
        print(
            f"|   per process, PSS MiB (last run) | {', '.join(f'{n} {v:.0f}' for n, v in sorted(per.items(), key=lambda kv: -kv[1]))} | | | |"
        )
        rested = [x for x in launches if x["rest_pct"] is not None]
        if rested:
            rest_master = median([x["master_rest_pct"] or 0.0 for x in rested])
            rest = median([x["rest_pct"] for x in rested]) + rest_master
            row(
                f"  CPU at rest (in its first state, {rested[0]['rest_state']}, from {REST_SETTLE:g} s after it "
                f"until the next state change: {spread([x['rest_s'] for x in rested], '.1f')} s), all processes"
                f"{' (with rosmaster, rosout)' if key == 'launch' else ''}, % of a core",
                f"**{rest:.2f}** (launch {spread([x['rest_pct'] for x in rested], '.2f')}"
                + (
                    f"; master {spread([x['master_rest_pct'] for x in rested], '.2f')})"
                    if key == "launch"
                    else ")"
                ),
                f"<= {TARGETS['idle_pct']:g}",
                rest <= TARGETS["idle_pct"],
                at,
            )
            per_rest = rested[-1]["per_node_rest"]
            print(
                f"|   per process at rest, % of a core (last run) | {', '.join(f'{n} {v:.2f}' for n, v in sorted(per_rest.items(), key=lambda kv: -kv[1]))} | | | |"
            )
        master = median([x["master_idle_pct"] for x in launches])
        idle = median([x["idle_pct"] for x in launches]) + master
        row(
            f"  CPU over the next {idle_seconds:g} s ({spread([x['idle_changes'] for x in launches], '.0f')} state changes), "
            f"all processes{' (with rosmaster, rosout)' if key == 'launch' else ''}, % of a core",
            f"{idle:.2f} (launch {figure('idle_pct', '.2f')}"
            + (
                f"; master {figure('master_idle_pct', '.2f')}, PSS {figure('master_pss', '.0f')} MiB)"
                if key == "launch"
                else ")"
            ),
            f"<= {TARGETS['idle_pct']:g}",
            idle <= TARGETS["idle_pct"],
            at,
        )
        per_idle = launches[-1]["per_node_idle"]
        print(
            f"|   per process, % of a core (last run) | {', '.join(f'{n} {v:.2f}' for n, v in sorted(per_idle.items(), key=lambda kv: -kv[1]))} | | | |"
        )


def still_robot(folder: Path) -> Path:
    """The packaged robot without the motivator's events of its idle state (it would wander or
    play music by itself): the same processes, nodes and topics, at rest until spoken to."""
    import yaml

    config = yaml.safe_load((DATA / "cyborg.yaml").read_text(encoding="utf-8"))
    events = config["motivator"]["events"]
    config["motivator"]["events"] = [e for e in events if e["state"] != config["initial"]]
    path = folder / "still.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False), encoding="utf-8")
    return path


ROS_CORE: list[subprocess.Popen[Any]] = []
LAUNCHED_ENTRY: list[bool] = []  # whether the code measured has cyborg.run.launched
LAUNCH_CONFIG: list[Path] = []  # --config: what the launches run (default: the packaged robot)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3, help="runs of each measurement (medians)")
    parser.add_argument("--sim-seconds", type=float, default=30.0, help="how long cyborg sim runs")
    parser.add_argument(
        "--idle-seconds", type=float, default=20.0, help="how long a launch's idle CPU is read"
    )
    parser.add_argument("--src", type=Path, help="measure this checkout's src folder (PYTHONPATH)")
    parser.add_argument(
        "--config",
        type=Path,
        help="the configuration the launches run (default: the packaged robot, which starts wandering; "
        "src/cyborg/data/demo.yaml's placeholders wait in their idle state)",
    )
    parser.add_argument(
        "--still",
        action="store_true",
        help="launch the packaged robot with nothing for its motivator to choose in the idle state: it "
        "stays in idle, the base still (the CPU at rest is read over --idle-seconds too)",
    )
    parser.add_argument(
        "--only",
        default="help,say,sim,node,node2,launch,launch2",
        help="comma-separated: help,say,sim,node,node2,launch,launch2 (node: ROS 1, node2: ROS 2)",
    )
    parser.add_argument("--role", choices=["floor", "floor2", "watch", "watch2"], help=argparse.SUPPRESS)
    args = parser.parse_args()
    roles = {"floor": role_floor, "floor2": role_floor2, "watch": role_watch, "watch2": role_watch2}
    if args.role is not None:
        roles[args.role]()
        return
    if args.config is not None and args.still:
        raise SystemExit("--config and --still exclude each other: pick one")
    if args.config is not None:
        LAUNCH_CONFIG.append(args.config.resolve())
    if ((args.src or ROOT / "src") / "cyborg" / "run" / "launched.py").is_file():
        LAUNCHED_ENTRY.append(True)
    if args.still:
        LAUNCH_CONFIG.append(still_robot(Path(tempfile.mkdtemp(prefix="cyborg-bench-still-"))))
    parts = {p.strip() for p in args.only.split(",") if p.strip()}
    if parts & {"node", "launch"} and shutil.which("roscore") is None:
        raise SystemExit("no roscore; fix: scripts/install-ros")
    try:
        out = bench(parts, args.runs, args.sim_seconds, args.idle_seconds, args.src)
    finally:
        if args.still:
            shutil.rmtree(LAUNCH_CONFIG[0].parent, ignore_errors=True)
    report(out, args.runs, args.sim_seconds, args.idle_seconds, args.src)


if __name__ == "__main__":
    main()
