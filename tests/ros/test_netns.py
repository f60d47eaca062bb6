"""Two hosts on one machine: the controller and the navigation module in two network namespaces.

Namespace A holds roscore, the controller (`cyborg node cyborg_controller`), an idle module
and a probe; namespace B holds the navigation module (`cyborg node cyborg_navigation`). They
are joined by a veth pair, 10.200.1.1 (A) and 10.200.1.2 (B), and each node advertises its
veth address with ROS_IP, as on the robot with several computers. Nothing is shared but that
link: no loopback, no hostname resolution. Needs root (CI runs the tests as root).

Checked: the navigation module registers with the master across the link; the controller sends
it goals and cancels across it, and acts on the event the module registers; the module's
result (aborted: no robot base here) comes back.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.support.ros import NodeProcess, Processes

HERE = Path(__file__).resolve().parent
MACHINE = HERE / "netns.yaml"
ADDRESS_A, ADDRESS_B = "10.200.1.1", "10.200.1.2"
MASTER_PORT = 11311  # namespace A has a port space of its own

# Runs in namespace A: prints every state change, and registers `navigation_emotional` once
# the controller is idle; prints where the master says the two nodes are.
PROBE = """
import time
import rosgraph, rospy
from cyborg_controller.msg import SystemState
from std_msgs.msg import String

rospy.init_node("netns_probe")
events = rospy.Publisher("/cyborg_controller/register_event", String, queue_size=10)
sent = []

def on_change(m):
    print("STATE", m.from_system_state or "-", m.event, m.to_system_state, time.monotonic(), flush=True)
    if m.to_system_state == "idle" and not sent:
        sent.append(m)
        while events.get_num_connections() < 1 and not rospy.is_shutdown():
            rospy.sleep(0.01)
        events.publish("navigation_emotional")

rospy.Subscriber("/cyborg_controller/state_change", SystemState, on_change)
master = rosgraph.Master("/netns_probe")
for name in ("/cyborg_controller", "/cyborg_navigation"):
    while not rospy.is_shutdown():
        try:
            print("NODE", name, master.lookupNode(name), flush=True)
            break
        except rosgraph.MasterError:
            rospy.sleep(0.05)
print("probe ready", flush=True)
rospy.spin()
"""


def _ip(*args: str) -> None:
    done = subprocess.run(["ip", *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(f"`ip {' '.join(args)}` failed ({done.returncode}): {done.stderr.strip()}")


@dataclass(frozen=True)
class Link:
    a: str  # the two namespaces' names
    b: str


def inside(namespace: str) -> list[str]:
    """The command prefix that runs a program in ``namespace`` (same pid: ip execs it)."""
    return ["ip", "netns", "exec", namespace]


@pytest.fixture
def link() -> Iterator[Link]:
    """Namespaces A and B joined by a veth pair; names unique to this pytest process."""
    assert os.geteuid() == 0, "network namespaces need root: run the tests as root (CI does)"
    tag = f"cyb{os.getpid()}"
    ns = Link(f"{tag}a", f"{tag}b")
    created: list[str] = []
    try:
        for name in (ns.a, ns.b):
            _ip("netns", "add", name)
            created.append(name)
        _ip("link", "add", f"{tag}a0", "type", "veth", "peer", "name", f"{tag}b0")
        for name, device, address in ((ns.a, f"{tag}a0", ADDRESS_A), (ns.b, f"{tag}b0", ADDRESS_B)):
            _ip("link", "set", device, "netns", name)
            _ip("-n", name, "addr", "add", f"{address}/24", "dev", device)
            _ip("-n", name, "link", "set", device, "up")
            _ip("-n", name, "link", "set", "lo", "up")
        yield ns
    finally:
        for name in created:  # deleting a namespace deletes its end of the veth pair, and so both
            subprocess.run(["ip", "netns", "del", name], capture_output=True)


def _env(address: str, home: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("ROS_HOSTNAME", "ROS_IP", "ROS_MASTER_URI")}
    env.update(ROS_IP=address, ROS_MASTER_URI=f"http://{ADDRESS_A}:{MASTER_PORT}", ROS_HOME=str(home))
    return env


def _lines(process: NodeProcess, prefix: str) -> list[str]:
    return [line for line in process.log().splitlines() if line.startswith(prefix)]


def _states(probe: NodeProcess) -> list[tuple[str, float]]:
    """The probe's state changes: ("from event to", when)."""
    return [(line.rsplit(" ", 1)[0][6:], float(line.rsplit(" ", 1)[1])) for line in _lines(probe, "STATE ")]


def _wait_state(probe: NodeProcess, change: str, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while change not in [c for c, _ in _states(probe)]:
        assert probe.process.poll() is None, f"the probe exited; log:\n{probe.log()[-3000:]}"
        assert time.monotonic() < deadline, f"no {change!r} within {timeout} s; probe:\n{probe.log()[-3000:]}"
        time.sleep(0.05)


def test_controller_and_navigation_in_two_network_namespaces(
    link: Link, processes: Processes, tmp_path: Path
) -> None:
    env_a, env_b = _env(ADDRESS_A, tmp_path / "home_a"), _env(ADDRESS_B, tmp_path / "home_b")
    master = processes.start(
        "roscore",
        [*inside(link.a), "roscore", "-p", str(MASTER_PORT)],
        "started core service [/rosout]",
        env=env_a,
        new_session=True,
    )
    processes.wait_ready(master)
    probe = processes.start("probe", [*inside(link.a), sys.executable, "-c", PROBE], "probe ready", env=env_a)
    idle = processes.cyborg_node(
        "cyborg_test_idle", MACHINE, tmp_path / "a", prefix=inside(link.a), env=env_a
    )
    navigation = processes.cyborg_node(
        "cyborg_navigation", MACHINE, tmp_path / "b", prefix=inside(link.b), env=env_b
    )
    controller = processes.cyborg_node(
        "cyborg_controller", MACHINE, tmp_path / "a", prefix=inside(link.a), env=env_a
    )
    processes.wait_ready(idle, navigation, controller, probe, timeout=60)

    nodes = dict(line.split()[1:3] for line in _lines(probe, "NODE"))
    assert re.fullmatch(rf"http://{re.escape(ADDRESS_A)}:\d+/", nodes["/cyborg_controller"])
    assert re.fullmatch(rf"http://{re.escape(ADDRESS_B)}:\d+/", nodes["/cyborg_navigation"])

    # idle -> planning (goal to B) -> B registers navigation_start_wandering (event to A) ->
    # A cancels planning and sends moving -> B aborts (no robot base here) -> idle.
    _wait_state(probe, "navigation_moving aborted idle", timeout=20)
    states = _states(probe)
    assert [change for change, _ in states] == [
        "- start idle",
        "idle navigation_emotional navigation_planning",
        "navigation_planning navigation_start_wandering navigation_moving",
        "navigation_moving aborted idle",
    ]
    # The module's own result, not the controller's connect timeout (5 s) taking 'aborted':
    assert states[3][1] - states[2][1] < 3.0
    for process in (master, probe, idle, navigation, controller):
        assert process.process.poll() is None, f"{process.name} died; log:\n{process.log()[-2000:]}"
