"""Footprint of the robot's processes, beside a bare rospy node measured in the same run.

* floor: a plain python script (this venv's python) that does ``rospy.init_node`` and serves one
  ``actionlib.SimpleActionServer`` on ``cyborg_controller/StateMachine``; its RSS once serving.
* node: ``cyborg node NAME`` of a placeholder module (demo.yaml's ``cyborg_joke``, kind
  ``placeholder``) and of a question module of the default config (cyborg.yaml's ``cyborg_joke``,
  the thesis's joke state); RSS once it logs ``node NAME running`` (its action server is up).
* launch: ``cyborg launch`` of the default config against a running master (started by the
  benchmark): wall time from its start until the controller's first message on
  ``/cyborg_controller/state_change``, and the RSS of each node process at that moment and 5 s later.
* say: ``cyborg say hello`` against a running embedded ``cyborg sim`` (its API on a free port),
  and ``cyborg --help``: wall time of the whole command, medians.
* sim: embedded ``cyborg sim`` (default config, real time), a fresh one each run: peak RSS (VmHWM)
  over ``--sim-seconds`` and RSS at the end (the robot starts wandering ~12 s in: one route planned).

RSS is VmRSS (VmHWM for peaks) from /proc, read 1 s after the process said it is ready; every
figure is the median of ``--runs`` runs, and each node's RSS is also given as a ratio to the floor's
median from the same run. The processes run with ``PYTHONPATH=--src`` first when given (a checkout's
``src`` folder, to measure an older commit beside the working tree). The benchmark starts its own
roscore on a free port with a temporary ROS_HOME and stops everything it started (process groups).

Run: .venv/bin/python benchmarks/bench_footprint.py [--runs 3] [--sim-seconds 30] [--src DIR]
     [--only floor,node,launch,say,help,sim]
"""

from __future__ import annotations

import argparse
import contextlib
import os
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
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from _machine import machine_line

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "src" / "cyborg" / "data"
STATE_CHANGE = "/cyborg_controller/state_change"
SETTLE = 1.0  # seconds between "ready" and reading the RSS
MB = 1024 * 1024
TARGETS = {  # issue 13
    "node_ratio": 1.3,
    "launch_s": 10.0,
    "say_s": 0.3,
    "sim_peak_mb": 150.0,
}
ISSUE_BEFORE = "node ~77 MB (floor 46 MB), launch ~27 s, --help 0.7 s, say ~0.7 s"


# --- the floor's own process ----------------------------------------------------------------------


def role_floor() -> None:
    """A bare rospy node serving one action: what any Python ROS node must hold."""
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
    return words[words.index("node") + 1] if "node" in words else " ".join(words[:3])


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


def cyborg(*args: str) -> list[str]:
    """The ``cyborg`` console script's import path (``from cyborg.cli import main``)."""
    return [
        sys.executable,
        "-c",
        "import sys; from cyborg.cli import main; sys.exit(main())",
        *args,
    ]


def measure_floor(env: dict[str, str], log_dir: Path) -> float:
    child = Child([sys.executable, __file__, "--role", "floor"], env, log_dir, "floor")
    try:
        child.wait_line("floor serving")
        time.sleep(SETTLE)
        return rss_mb(child.pid)
    finally:
        child.stop()


def measure_node(env: dict[str, str], log_dir: Path, name: str, config: Path) -> float:
    data = Path(tempfile.mkdtemp(prefix="cyborg-bench-db-", dir=log_dir))
    child = Child(cyborg("node", name, "--config", str(config), "--db", str(data)), env, log_dir, name)
    try:
        child.wait_line(f"node {name} running")
        time.sleep(SETTLE)
        return rss_mb(child.pid)
    finally:
        child.stop()


def measure_launch(env: dict[str, str], log_dir: Path) -> tuple[float, dict[str, float], dict[str, float]]:
    """Seconds until the first state change; each node's RSS then and 5 s later."""
    import rospy

    heard = threading.Event()
    data = Path(tempfile.mkdtemp(prefix="cyborg-bench-db-", dir=log_dir))
    port = free_port()
    from cyborg_controller.msg import SystemState  # type: ignore[import-not-found]

    subscriber = rospy.Subscriber(STATE_CHANGE, SystemState, lambda _m: heard.set(), queue_size=10)
    time.sleep(0.2)
    child = Child(cyborg("launch", "--db", str(data), "--port", str(port)), env, log_dir, "launch")
    try:
        if not heard.wait(120):
            raise SystemExit(f"no state change within 120 s; launch log:\n{child.log()[-3000:]}")
        first = time.perf_counter() - child.started
        at_first = {node_name(pid): rss_mb(pid) for pid in children_of(child.pid)}
        time.sleep(5)
        later = {node_name(pid): rss_mb(pid) for pid in children_of(child.pid)}
        return first, at_first, later
    finally:
        subscriber.unregister()
        child.stop()


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


def bench(parts: set[str], runs: int, sim_seconds: float, src: Path | None) -> dict[str, Any]:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src.resolve()) + (
            os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else ""
        )
        os.environ["PYTHONPATH"] = env[
            "PYTHONPATH"
        ]  # sys.executable children only; this process imports rospy
    out: dict[str, Any] = {}
    log_dir = Path(tempfile.mkdtemp(prefix="cyborg-bench-footprint-"))
    try:
        if parts & {"floor", "node", "launch"}:
            with ros_graph(env) as ros_env:
                os.environ.update({k: ros_env[k] for k in ("ROS_MASTER_URI", "ROS_HOSTNAME", "ROS_HOME")})
                floor: list[float] = []
                placeholder: list[float] = []
                question: list[float] = []
                for _ in range(runs):  # alternating, so load changes hit all alike
                    floor.append(measure_floor(ros_env, log_dir))
                    if "node" in parts:
                        placeholder.append(measure_node(ros_env, log_dir, "cyborg_joke", DATA / "demo.yaml"))
                        question.append(measure_node(ros_env, log_dir, "cyborg_joke", DATA / "cyborg.yaml"))
                out["floor"] = floor
                if placeholder:
                    out["placeholder"] = placeholder
                    out["question"] = question
                if "launch" in parts:
                    import rospy

                    rospy.init_node("bench_footprint", disable_signals=True)
                    launches = [measure_launch(ros_env, log_dir) for _ in range(runs)]
                    out["launch"] = [first for first, _, _ in launches]
                    out["launch_rss"] = [at for _, at, _ in launches]
                    out["launch_rss_later"] = [later for _, _, later in launches]
                    rospy.signal_shutdown("benchmark done")
        if "help" in parts:
            wall(cyborg("--help"), env)  # warm the file cache
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
                        out["say"] = [wall(say, env) for _ in range(max(5, runs))]
                    if "sim" in parts:
                        remaining = sim_seconds - (time.perf_counter() - sim.started)
                        time.sleep(max(0.0, remaining))
                        peaks.append(rss_mb(sim.pid, "VmHWM"))
                        settled.append(rss_mb(sim.pid))
                finally:
                    sim.stop()
            if peaks:
                out["sim_peak"] = peaks
                out["sim_rss"] = settled
    finally:
        shutil.rmtree(log_dir, ignore_errors=True)
    return out


def report(out: dict[str, Any], runs: int, sim_seconds: float, src: Path | None) -> None:
    print(f"machine: {machine_line()}")
    print(f"code: {src if src is not None else 'this working tree'}; medians of {runs} runs (min-max)")
    print(f"issue 13 (before): {ISSUE_BEFORE}")
    print("| what | figure | target | |")
    print("|---|---:|---|---|")

    def row(what: str, figure: str, target: str = "", ok: bool | None = None) -> None:
        verdict = "" if ok is None else ("pass" if ok else "FAIL")
        print(f"| {what} | {figure} | {target} | {verdict} |")

    floor = median(out["floor"]) if "floor" in out else None
    if floor is not None:
        row("floor: bare rospy node + SimpleActionServer, RSS MB", spread(out["floor"], ".1f"))
    if "placeholder" in out and floor is not None:
        for key, label in (
            ("placeholder", "cyborg node cyborg_joke (demo.yaml, placeholder)"),
            ("question", "cyborg node cyborg_joke (cyborg.yaml, question)"),
        ):
            ratio = median(out[key]) / floor
            row(f"{label}, RSS MB", spread(out[key], ".1f"))
            limit = TARGETS["node_ratio"]
            row(
                "  ratio to the floor",
                f"{ratio:.2f}",
                f"<= {limit}" if key == "placeholder" else "",
                ratio <= limit if key == "placeholder" else None,
            )
    if "launch" in out:
        first = median(out["launch"])
        row(
            "cyborg launch: first state, s",
            spread(out["launch"], ".1f"),
            f"<= {TARGETS['launch_s']:g}",
            first <= TARGETS["launch_s"],
        )
        for label, key in (("at the first state", "launch_rss"), ("5 s later", "launch_rss_later")):
            per_node: dict[str, list[float]] = {}
            for sample in out[key]:
                for name, mb in sample.items():
                    per_node.setdefault(name, []).append(mb)
            medians = {name: median(values) for name, values in per_node.items()}
            total = sum(medians.values())
            biggest = max(medians.values(), default=0.0)
            line = ", ".join(
                f"{name} {mb:.0f}" for name, mb in sorted(medians.items(), key=lambda kv: -kv[1])
            )
            row(
                f"launch nodes' RSS {label}: {len(medians)} nodes, sum MB", f"{total:.0f} (max {biggest:.0f})"
            )
            print(f"|   per node, MB | {line} | | |")
            if floor is not None and medians:
                row(f"  median node / floor ({label})", f"{median(list(medians.values())) / floor:.2f}")
    if "help" in out:
        row("cyborg --help, wall s", spread(out["help"], ".3f"))
    if "say" in out:
        say = median(out["say"])
        row(
            "cyborg say hello (embedded sim), wall s",
            spread(out["say"], ".3f"),
            f"<= {TARGETS['say_s']}",
            say <= TARGETS["say_s"],
        )
    if "sim_peak" in out:
        peak = median(out["sim_peak"])
        row(
            f"cyborg sim peak RSS (VmHWM) over {sim_seconds:g} s, MB",
            spread(out["sim_peak"], ".0f"),
            f"<= {TARGETS['sim_peak_mb']:g}",
            peak <= TARGETS["sim_peak_mb"],
        )
        row(f"cyborg sim RSS after {sim_seconds:g} s, MB", spread(out["sim_rss"], ".0f"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3, help="runs of each measurement (medians)")
    parser.add_argument("--sim-seconds", type=float, default=30.0, help="how long cyborg sim runs")
    parser.add_argument("--src", type=Path, help="measure this checkout's src folder (PYTHONPATH)")
    parser.add_argument(
        "--only",
        default="floor,node,launch,say,help,sim",
        help="comma-separated: floor,node,launch,say,help,sim (the floor comes with node and launch)",
    )
    parser.add_argument("--role", choices=["floor"], help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role == "floor":
        role_floor()
        return
    parts = {p.strip() for p in args.only.split(",") if p.strip()}
    if parts & {"node", "launch"}:
        parts.add("floor")
    if "floor" in parts and shutil.which("roscore") is None:
        raise SystemExit("no roscore; fix: scripts/install-ros")
    out = bench(parts, args.runs, args.sim_seconds, args.src)
    report(out, args.runs, args.sim_seconds, args.src)


if __name__ == "__main__":
    main()
