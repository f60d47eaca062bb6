"""Who else is on the graph: a node refuses a name in use, a robot refuses another robot's graph.

ROS names nodes, not robots, so two robots (or a student's laptop running ``cyborg launch``) on
one ROS 2 domain, or one ROS 1 master, become one confused robot, and two nodes of one name
break that name's topics and actions. So before a node joins with its name:

- ROS 1: the master knows every node; a node of the name whose own XML-RPC server still
  answers is alive (rospy would shut it down silently and take its place). A dead one (killed,
  being started again by a launch) is replaced as usual.
- ROS 2: there is no master; the node looks at the graph until discovery has shown what runs
  there (it is not instant), and a node of its name that is still there after PARTICIPANT_LEASE (a
  process just killed lingers that long) is alive. Discovery shows the nodes of a process that
  was running already about as soon as those of one started beside this one: so the look ends
  SETTLE_AFTER_OTHERS seconds after the graph first shows a node of another process (a launch's
  nodes see each other within a few tenths of a second), and after DISCOVERY_SETTLE seconds on a
  graph that shows none.

Either refuses with :class:`NameTaken`, naming the node and the fix; ``cyborg node`` ends with
exit code NAME_TAKEN_EXIT, which tells ``cyborg launch`` to stop the whole robot with that
message instead of starting the node again. The controller's node also refuses a graph that has
the parameter home ``/cyborg_parameters`` (over ROS 2 the controller hosts it: another's answers
for it, or, a leftover, answers nothing). :func:`graph_name` says which graph a process is on,
for the launch's first lines and the dashboard.
"""

from __future__ import annotations

import os
import time
import urllib.parse
from collections.abc import Callable, Iterable
from typing import Any

from cyborg.errors import CyborgError

__all__ = [
    "DISCOVERY_SETTLE",
    "NAME_TAKEN_EXIT",
    "SETTLE_AFTER_OTHERS",
    "NameTaken",
    "graph_name",
    "robot_taken_message",
    "ros1_live_nodes",
    "ros2_domain_problem",
    "taken_message",
    "wait_for_graph",
]

NAME_TAKEN_EXIT = 76
"""Exit code of ``cyborg node`` refusing a name in use (the launch stops instead of retrying)."""
DISCOVERY_SETTLE = 1.5  # seconds a ROS 2 node looks at an empty graph before it takes its name (best effort: discovery under heavy load can take longer)
SETTLE_AFTER_OTHERS = 0.5  # seconds it looks on once the graph shows another process's node (discovery works)
GHOST_WAIT = 2.0  # seconds a ROS 2 name seen may take to vanish (a just-killed process's lease)
PING_TIMEOUT = 1.0  # seconds a ROS 1 node's XML-RPC server has to answer
ROS2_DEFAULT_RANGE = "SUBNET"  # ROS_AUTOMATIC_DISCOVERY_RANGE when it is not set (ROS 2 Jazzy and later)


class NameTaken(CyborgError):
    """A node of this name (or the controller's parameter home) is already on the graph."""


def graph_name(middleware: str) -> str:
    """Which graph this process joins, for people: ``ROS 2 domain 42 (discovery: this machine only)``."""
    if middleware == "ROS 1":
        return f"ROS 1 master {os.environ.get('ROS_MASTER_URI', 'http://localhost:11311')}"
    domain = os.environ.get("ROS_DOMAIN_ID", "").strip() or "0 (ROS_DOMAIN_ID not set)"
    reach = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper() or ROS2_DEFAULT_RANGE
    where = {
        "LOCALHOST": "this machine only",
        "SUBNET": "the local network",
        "OFF": "off",
        "SYSTEM_DEFAULT": "the DDS default",
    }.get(reach, reach)
    peers = os.environ.get("ROS_STATIC_PEERS", "").strip()
    return f"ROS 2 domain {domain} (discovery: {where}{f'; static peers {peers}' if peers else ''})"


def ros2_domain_problem() -> str | None:
    """Why this environment would put a robot on a shared ROS 2 graph by accident, or None.

    Unset ``ROS_DOMAIN_ID`` means domain 0, where every ROS 2 program on the network meets unless
    discovery is kept on this machine: a robot must be put on a domain deliberately.
    """
    if os.environ.get("ROS_DOMAIN_ID", "").strip():
        return None
    reach = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper() or ROS2_DEFAULT_RANGE
    if reach in ("LOCALHOST", "OFF"):
        return None
    return (
        "ROS_DOMAIN_ID is not set: this robot would join ROS 2 domain 0, which every ROS 2 program on "
        f"the network shares (discovery: {reach}), and merge with any other robot there; fix: give "
        "it a domain of its own, e.g. `export ROS_DOMAIN_ID=42` (0-101, one per robot on the "
        "network; the command tool needs the same), or keep it on this machine with "
        "`export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (docs/security.md)"
    )


def taken_message(name: str, graph: str, where: str = "", *, home: bool = False) -> str:
    """The refusal of node ``name`` (or, with ``home``, of the parameter home) on ``graph``."""
    at = f" ({where})" if where else ""
    if home:
        return (
            f"a node /{name} is already on {graph}{at}, without this robot's controller: another "
            "robot's parameter home, or one left over from a robot that did not stop cleanly; this "
            "controller hosts the parameters there and would read and write a stranger's; fix: stop "
            "that process, or give this robot a graph of its own (ROS_DOMAIN_ID=N, docs/security.md)"
        )
    if name == "cyborg_controller":
        return robot_taken_message(name, graph, where)
    return (
        f"a node /{name} already runs on {graph}{at}; two nodes of one name break its topics and "
        f"actions (every goal of a module would end LOST); fix: stop that one first (it may be part "
        "of a `cyborg launch`), or run this one on another graph"
    )


def robot_taken_message(name: str, graph: str, where: str = "") -> str:
    """The controller's node ``name`` is taken on ``graph``: another robot runs there."""
    at = f" ({where})" if where else ""
    return (
        f"another robot runs on {graph}: its node /{name} answers there{at}; two robots on one graph take each other's events and state changes and "
        "say every sentence twice; fix: stop that robot, or give this one a graph of its own (ROS 2: "
        "ROS_DOMAIN_ID=N, 0-101, one per robot; ROS 1: ROS_MASTER_URI=http://localhost:PORT; "
        "docs/security.md)"
    )


def wait_for_graph(
    names_now: Callable[[], set[str]],
    wanted: Iterable[str],
    *,
    settle: float = DISCOVERY_SETTLE,
    own: Iterable[str] = (),
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> set[str]:
    """Which of ``wanted`` are on a ROS 2 graph and stay there (see the module's doc).

    ``names_now()`` lists the node names the graph shows now (discovery fills it over time);
    ``own``: this process's own (hidden) nodes, which say nothing about discovery.
    """
    wanted = set(wanted)
    own = set(own)
    deadline = clock() + settle
    seen: set[str] = set()
    while clock() < deadline:
        names = names_now()
        seen |= names & wanted
        if names - own:  # discovery has shown another process: what ran already shows as soon
            deadline = min(deadline, clock() + SETTLE_AFTER_OTHERS)
        sleep(0.05)
    if not seen:
        return set()
    deadline = clock() + GHOST_WAIT
    while seen and clock() < deadline:
        seen &= names_now()
        sleep(0.1)
    return seen


def ros1_live_nodes(names: Iterable[str], master_uri: str) -> dict[str, str]:
    """Of ``names``, those the ROS 1 master at ``master_uri`` knows and whose node answers: name ->
    ``process N on HOST``."""
    import xmlrpc.client  # (here: a ROS 2 node imports this module, and needs no XML-RPC)

    class _TimeoutTransport(xmlrpc.client.Transport):
        def __init__(self, timeout: float) -> None:
            super().__init__()
            self._timeout = timeout

        def make_connection(self, host: Any) -> Any:
            connection = super().make_connection(host)
            connection.timeout = self._timeout
            return connection

    master = xmlrpc.client.ServerProxy(master_uri, transport=_TimeoutTransport(PING_TIMEOUT))
    live: dict[str, str] = {}
    for name in names:
        try:
            answer: Any = master.lookupNode("/cyborg_census", "/" + name.lstrip("/"))
        except (OSError, xmlrpc.client.Error):
            return live  # no master: nothing is taken
        if answer[0] != 1:
            continue
        address = urllib.parse.urlparse(str(answer[2]))
        scheme = "https" if address.scheme == "https" else "http"
        node = xmlrpc.client.ServerProxy(
            f"{scheme}://{address.netloc}", transport=_TimeoutTransport(PING_TIMEOUT)
        )
        try:
            pid: Any = node.getPid("/cyborg_census")
        except (OSError, xmlrpc.client.Error):  # (a timeout is an OSError)
            continue  # registered, but gone: a new node of the name takes its place
        live[name] = f"process {pid[2]} on {address.hostname}"
    return live
