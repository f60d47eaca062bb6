#!/usr/bin/env python3
"""End-to-end smoke test of ROS 1 from Debian's packages with this tree's messages.

Usage:  .venv/bin/python ros/smoke_test.py [--prefix .venv/ros] [--rounds 500]

Needs scripts/install-ros to have run (Debian packages, venv wiring, generated messages
under PREFIX).  It starts a real roscore on a free port (logs in a temporary ROS_HOME),
a server node in a subprocess (two SimpleActionServers of cyborg_controller/StateMachine,
a SystemState publisher, the EmotionalStateService) and, in this process, a client node that:
  - sends a goal, cancels it and gets PREEMPTED (the server calls set_preempted);
  - subscribes to SystemState and reads the sender's caller id from the connection header;
  - sets and gets parameters (rospy and the rosparam CLI);
  - calls the service (rospy and the rosservice CLI);
  - runs `rostopic echo -n 1`, `rosmsg show`, `rossrv show`, `rosmsg md5` as subprocesses;
then measures the controller's state-change round trip (cancel the running goal, wait for
PREEMPTED, send the next goal, wait until it is ACTIVE) over --rounds rounds, with
--tcp-nodelay also with TCP_NODELAY on every subscriber.
Prints one line per check and ends with 'smoke: N passed, N failed'.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SERVER_NODE = "smoke_server"
STATE_TOPIC = "/cyborg_controller/state_change"
SERVICE = "/cyborg_controller/get_emotional_state"
ACTIONS = (f"/{SERVER_NODE}/idle", f"/{SERVER_NODE}/moving")


def force_tcp_nodelay() -> None:
    """Make every rospy.Subscriber ask its publishers for TCP_NODELAY (actionlib's own
    subscribers don't, and Nagle's algorithm + delayed ACKs then add ~40 ms now and then)."""
    import rospy.topics

    original = rospy.topics.Subscriber.__init__

    def init(self, *args, tcp_nodelay=True, **kwargs):
        original(self, *args, tcp_nodelay=tcp_nodelay, **kwargs)

    rospy.topics.Subscriber.__init__ = init


# --------------------------------------------------------------------------- server role
def run_server() -> int:
    if os.environ.get("CYBORG_SMOKE_TCP_NODELAY") == "1":
        force_tcp_nodelay()
    import actionlib
    import rospy
    from cyborg_controller.msg import StateMachineAction, StateMachineResult, SystemState
    from cyborg_controller.srv import EmotionalStateService, EmotionalStateServiceResponse

    # disable_signals: rospy would otherwise install its own SIGINT/SIGTERM handlers.
    rospy.init_node(SERVER_NODE, disable_signals=True)

    def make_server(name: str) -> actionlib.SimpleActionServer:
        preempted = threading.Event()

        def execute(goal) -> None:
            # Runs in the server's own thread until the goal is preempted (cancel or a newer goal)
            # or, for event "finish", succeeds at once.  Waiting on an Event set by the preempt
            # callback instead of polling is_preempt_requested() at a rate keeps the latency low.
            if goal.event == "finish":
                server.set_succeeded(StateMachineResult(status="succeeded", message=goal.current_state))
                return
            preempted.clear()
            while not server.is_preempt_requested() and not rospy.is_shutdown():
                preempted.wait(1.0)
                preempted.clear()
            server.set_preempted(StateMachineResult(status="preempted", message=goal.current_state))

        # execute_cb must be given to the constructor: only then does it start the execute thread.
        server = actionlib.SimpleActionServer(name, StateMachineAction, execute_cb=execute, auto_start=False)
        server.register_preempt_callback(preempted.set)
        server.start()
        return server

    servers = [make_server(name) for name in ACTIONS]  # noqa: F841 - kept alive

    def emotional_state(_req):
        return EmotionalStateServiceResponse("neutral", 0.0, 0.25, -0.5)

    rospy.Service(SERVICE, EmotionalStateService, emotional_state)
    pub = rospy.Publisher(STATE_TOPIC, SystemState, queue_size=100)
    rate = rospy.Rate(20)
    n = 0
    while not rospy.is_shutdown():
        pub.publish(SystemState(event=f"tick{n}", from_system_state="idle", to_system_state="moving"))
        n += 1
        rate.sleep()
    return 0


# --------------------------------------------------------------------------- client role
class Checks:
    def __init__(self) -> None:
        self.passed = 0
        self.failed = 0

    def check(self, name: str, ok: bool, detail: str = "") -> None:
        if ok:
            self.passed += 1
        else:
            self.failed += 1
        print(f"{'ok  ' if ok else 'FAIL'} {name}{': ' + detail if detail else ''}", flush=True)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cli(args: list[str], env: dict[str, str], timeout: float = 30) -> subprocess.CompletedProcess:
    return subprocess.run(args, env=env, capture_output=True, text=True, timeout=timeout)


def stop(proc: subprocess.Popen | None, sig: int = signal.SIGINT, grace: float = 10) -> None:
    """Stop a child we started (it leads its own process group) and its children."""
    if proc is None or proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, sig)
        proc.wait(grace)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(5)
    except ProcessLookupError:
        pass


def percentile(values: list[float], p: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(p / 100 * len(ordered)) - 1))]


def run_client(prefix: Path, rounds: int, tcp_nodelay: bool) -> int:
    if tcp_nodelay:
        force_tcp_nodelay()
    port = free_port()
    ros_home = Path(tempfile.mkdtemp(prefix="cyborg-ros-home-"))
    env = dict(os.environ)
    env.update(
        ROS_MASTER_URI=f"http://localhost:{port}",
        ROS_HOSTNAME="localhost",
        ROS_HOME=str(ros_home),
        ROS_PACKAGE_PATH=str(prefix / "share"),
        PYTHONPATH=os.pathsep.join(
            filter(None, [str(prefix / "lib" / "python"), os.environ.get("PYTHONPATH")])
        ),
    )
    env.pop("ROS_IP", None)
    env["CYBORG_SMOKE_TCP_NODELAY"] = "1" if tcp_nodelay else "0"
    os.environ.update(env)  # rospy in this process reads them at import/init time
    checks = Checks()
    core = server = None
    try:
        t0 = time.perf_counter()
        core = subprocess.Popen(
            ["roscore", "-p", str(port)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            start_new_session=True,
        )
        import rosgraph

        master = rosgraph.Master("/smoke_client")
        deadline = time.monotonic() + 30
        while True:
            try:
                master.getSystemState()  # rosout registers once the core is up
                if master.lookupNode("/rosout"):
                    break
            except Exception:
                pass
            if time.monotonic() > deadline or core.poll() is not None:
                raise SystemExit(
                    f"roscore did not come up: {core.stderr.read().decode() if core.poll() is not None else 'timeout'}"
                )
            time.sleep(0.05)
        checks.check(
            "roscore up", True, f"port {port}, {time.perf_counter() - t0:.2f} s until /rosout registered"
        )

        t0 = time.perf_counter()
        server = subprocess.Popen(
            [sys.executable, __file__, "--role", "server"], env=env, start_new_session=True
        )

        import actionlib
        import rospy
        from actionlib_msgs.msg import GoalStatus
        from cyborg_controller.msg import StateMachineAction, StateMachineGoal, SystemState
        from cyborg_controller.srv import EmotionalStateService

        rospy.init_node("smoke_client", disable_signals=True)

        clients = [actionlib.SimpleActionClient(name, StateMachineAction) for name in ACTIONS]
        for c, name in zip(clients, ACTIONS, strict=True):
            checks.check(f"action server {name} found", c.wait_for_server(rospy.Duration(30)))
        checks.check(
            "server node up",
            True,
            f"{time.perf_counter() - t0:.2f} s from spawn to both action servers found",
        )

        # --- publisher/subscriber with the caller id from the connection header
        got: list = []
        seen = threading.Event()

        def on_state(msg) -> None:
            got.append((msg.to_system_state, msg._connection_header.get("callerid")))
            seen.set()

        sub = rospy.Subscriber(STATE_TOPIC, SystemState, on_state, queue_size=100)
        checks.check("SystemState received", seen.wait(15), repr(got[:1]))
        checks.check(
            "caller id from connection header",
            bool(got) and got[0][1] == f"/{SERVER_NODE}",
            repr(got[0][1] if got else None),
        )
        sub.unregister()

        # --- goal, cancel, PREEMPTED
        c = clients[0]
        active = threading.Event()
        c.send_goal(
            StateMachineGoal(previous_state="idle", event="navigation_command", current_state="moving"),
            active_cb=active.set,
        )
        checks.check("goal became ACTIVE", active.wait(10))
        c.cancel_goal()
        c.wait_for_result(rospy.Duration(10))
        result = c.get_result()
        checks.check(
            "cancel -> PREEMPTED",
            c.get_state() == GoalStatus.PREEMPTED,
            f"state {c.get_state()}, result {result.status if result else None}/{result.message if result else None}",
        )
        c.send_goal(StateMachineGoal(previous_state="moving", event="finish", current_state="talking"))
        c.wait_for_result(rospy.Duration(10))
        checks.check(
            "goal -> SUCCEEDED",
            c.get_state() == GoalStatus.SUCCEEDED,
            f"result message {c.get_result().message!r}",
        )

        # --- parameters
        rospy.set_param("/cyborg_controller/resources", {"trollface": "cyborg_navigation"})
        checks.check(
            "rospy set/get_param",
            rospy.get_param("/cyborg_controller/resources") == {"trollface": "cyborg_navigation"},
        )
        r = cli(["rosparam", "set", "/cyborg_controller/mode", "demo"], env)
        checks.check("rosparam set (CLI)", r.returncode == 0, r.stderr.strip())
        r = cli(["rosparam", "get", "/cyborg_controller/resources"], env)
        checks.check(
            "rosparam get (CLI)",
            r.returncode == 0 and "trollface: cyborg_navigation" in r.stdout,
            r.stdout.strip() or r.stderr.strip(),
        )
        checks.check("rospy sees CLI param", rospy.get_param("/cyborg_controller/mode", None) == "demo")

        # --- service
        proxy = rospy.ServiceProxy(SERVICE, EmotionalStateService)
        proxy.wait_for_service(10)
        resp = proxy()
        checks.check(
            "service via rospy",
            resp.emotional_state == "neutral" and abs(resp.current_dominance + 0.5) < 1e-6,
            str(resp).replace("\n", ", "),
        )
        r = cli(["rosservice", "call", SERVICE], env)
        checks.check(
            "rosservice call (CLI)",
            r.returncode == 0 and 'emotional_state: "neutral"' in r.stdout,
            r.stdout.strip().replace("\n", ", ") or r.stderr.strip(),
        )

        # --- the stock CLI tools on our types
        r = cli(["rostopic", "echo", "-n", "1", STATE_TOPIC], env)
        checks.check(
            "rostopic echo -n 1",
            r.returncode == 0 and 'to_system_state: "moving"' in r.stdout,
            r.stdout.strip().replace("\n", ", ") or r.stderr.strip(),
        )
        r = cli(["rostopic", "type", STATE_TOPIC], env)
        checks.check(
            "rostopic type",
            r.stdout.strip() == "cyborg_controller/SystemState",
            r.stdout.strip() or r.stderr.strip(),
        )
        r = cli(["rosmsg", "show", "cyborg_controller/SystemState"], env)
        checks.check(
            "rosmsg show SystemState",
            r.stdout.split()
            == ["string", "event", "string", "from_system_state", "string", "to_system_state"],
            r.stdout.strip().replace("\n", ", ") or r.stderr.strip(),
        )
        r = cli(["rosmsg", "show", "cyborg_controller/StateMachineActionGoal"], env)
        checks.check(
            "rosmsg show StateMachineActionGoal",
            r.returncode == 0 and "actionlib_msgs/GoalID goal_id" in r.stdout,
            r.stderr.strip(),
        )
        r = cli(["rossrv", "show", "cyborg_controller/EmotionalStateService"], env)
        checks.check(
            "rossrv show EmotionalStateService",
            r.returncode == 0 and "string emotional_state" in r.stdout,
            r.stderr.strip(),
        )
        r = cli(["rosmsg", "md5", "cyborg_controller/SystemState"], env)
        checks.check(
            "rosmsg md5 == generated class",
            r.stdout.strip() == SystemState._md5sum,
            f"{r.stdout.strip()} vs {SystemState._md5sum}",
        )
        r = cli(["rosnode", "list"], env)
        checks.check(
            "rosnode list",
            {"/rosout", f"/{SERVER_NODE}", "/smoke_client"} <= set(r.stdout.split()),
            " ".join(r.stdout.split()),
        )

        # --- latency: the controller's state change (cancel current goal, wait PREEMPTED, send next, wait ACTIVE)
        if rounds > 0:
            measure(rounds, checks)
            measure_simple_active_race(min(rounds, 100), checks)
    finally:
        try:
            import rospy

            rospy.signal_shutdown("smoke test done")
        except Exception:
            pass
        stop(server, signal.SIGTERM)
        stop(core, signal.SIGINT)
        shutil.rmtree(ros_home, ignore_errors=True)
    print(f"smoke: {checks.passed} passed, {checks.failed} failed", flush=True)
    return 0 if checks.failed == 0 else 1


def measure(rounds: int, checks: Checks) -> None:
    """The controller's state change: cancel the running goal, wait for PREEMPTED, send the next
    goal, wait until the server has accepted it (ACTIVE).  Uses actionlib.ActionClient, whose
    transition callback gets the goal handle as an argument (SimpleActionClient can lose the
    ACTIVE transition: see measure_simple_active_race)."""
    import actionlib
    import rospy
    from actionlib_msgs.msg import GoalStatus
    from cyborg_controller.msg import StateMachineAction, StateMachineGoal

    clients = [actionlib.ActionClient(name, StateMachineAction) for name in ACTIONS]
    for c in clients:
        if not c.wait_for_server(rospy.Duration(30)):
            checks.check("latency: ActionClient found server", False)
            return

    def send(client, i):
        active, done = threading.Event(), threading.Event()

        def transition(gh) -> None:
            state = gh.get_comm_state()
            if state == actionlib.CommState.ACTIVE:
                active.set()
            elif state == actionlib.CommState.DONE:
                active.set()
                done.set()

        gh = client.send_goal(
            StateMachineGoal(previous_state="x", event=f"e{i}", current_state="y"), transition_cb=transition
        )
        if not active.wait(10):
            raise RuntimeError(f"goal {i} never became ACTIVE (comm state {gh.get_comm_state()})")
        return gh, done

    for label, pick in (
        ("alternating servers", lambda i: clients[i % 2]),
        ("same server", lambda i: clients[0]),
    ):
        gh, done = send(pick(0), 0)
        total, cancel, start = [], [], []
        for i in range(1, rounds + 1):
            t0 = time.perf_counter()
            gh.cancel()
            if not done.wait(10) or gh.get_goal_status() != GoalStatus.PREEMPTED:
                checks.check(f"latency round {i} ({label})", False, f"status {gh.get_goal_status()}")
                return
            t1 = time.perf_counter()
            gh, done = send(pick(i), i)
            t2 = time.perf_counter()
            total.append(t2 - t0)
            cancel.append(t1 - t0)
            start.append(t2 - t1)
        gh.cancel()
        done.wait(10)
        ms = lambda v, p: f"{percentile(v, p) * 1e3:.2f}"  # noqa: E731
        checks.check(
            f"latency {label}, {rounds} rounds",
            True,
            f"cancel->PREEMPTED->next goal ACTIVE p50 {ms(total, 50)} ms, p99 {ms(total, 99)} ms, max {max(total) * 1e3:.2f} ms "
            f"(cancel->PREEMPTED p50 {ms(cancel, 50)}/p99 {ms(cancel, 99)}; send->ACTIVE p50 {ms(start, 50)}/p99 {ms(start, 99)})",
        )


def measure_simple_active_race(rounds: int, checks: Checks) -> None:
    """Count how often SimpleActionClient.send_goal's active_cb never fires: the server's ACTIVE
    status can arrive before send_goal has stored the new goal handle, and the transition is then
    dropped ('Got a transition callback on a goal handle that we're not tracking').  Results and
    wait_for_result are not affected."""
    import actionlib
    import rospy
    from actionlib_msgs.msg import GoalStatus
    from cyborg_controller.msg import StateMachineAction, StateMachineGoal

    client = actionlib.SimpleActionClient(ACTIONS[0], StateMachineAction)
    client.wait_for_server(rospy.Duration(30))
    lost = 0
    preempted = 0
    for i in range(rounds):
        active = threading.Event()
        client.send_goal(
            StateMachineGoal(previous_state="x", event=f"s{i}", current_state="y"), active_cb=active.set
        )
        if not active.wait(0.5):
            lost += 1
        client.cancel_goal()
        client.wait_for_result(rospy.Duration(10))
        preempted += client.get_state() == GoalStatus.PREEMPTED
    checks.check(
        "SimpleActionClient cancel -> PREEMPTED every time", preempted == rounds, f"{preempted}/{rounds}"
    )
    print(
        f"info SimpleActionClient active_cb never called for {lost} of {rounds} goals (known actionlib race)",
        flush=True,
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--prefix",
        type=Path,
        default=HERE.parent / ".venv" / "ros",
        help="where ros/generate.py wrote (default: %(default)s)",
    )
    parser.add_argument("--rounds", type=int, default=500, help="latency rounds (0: skip)")
    parser.add_argument(
        "--tcp-nodelay", action="store_true", help="make all subscribers (actionlib's too) use TCP_NODELAY"
    )
    parser.add_argument("--role", choices=["client", "server"], default="client", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role == "server":
        return run_server()
    if shutil.which("roscore") is None:
        print("error: no roscore; fix: scripts/install-ros", file=sys.stderr)
        return 2
    if not (args.prefix / "lib" / "python" / "cyborg_controller").is_dir():
        print(
            f"error: no generated messages under {args.prefix}; fix: scripts/install-ros (or ros/generate.py {args.prefix})",
            file=sys.stderr,
        )
        return 2
    return run_client(args.prefix.resolve(), args.rounds, args.tcp_nodelay)


if __name__ == "__main__":
    sys.exit(main())
