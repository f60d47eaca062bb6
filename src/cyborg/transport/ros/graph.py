"""The ROS 1 graph as :class:`~cyborg.transport.graph.GraphView`: the master's state, and each
node's own answer (a node killed without unregistering stays listed by the master)."""

from __future__ import annotations

import xmlrpc.client
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from cyborg.transport.graph import GraphNode, GraphView
from cyborg.transport.ros.master import UNREACHABLE, _TimeoutTransport, master_proxy

__all__ = ["NODE_PING_TIMEOUT", "ros1_graph"]

NODE_PING_TIMEOUT = 1.0
"""Seconds a node's XML-RPC server may take to answer before it counts as gone."""
CALLER = "/cyborg_doctor"


def _answers(uri: str | None) -> bool:
    if not uri:
        return False
    proxy = xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(NODE_PING_TIMEOUT))
    try:
        reply: Any = proxy.getPid(CALLER)
    except UNREACHABLE:
        return False
    return bool(reply[0] == 1)


def ros1_graph(uri: str | None = None, *, ask_nodes: bool = True) -> GraphView:
    """The graph of the master at ``uri`` (default ROS_MASTER_URI); raises OSError and
    xmlrpc errors when the master does not answer. ``ask_nodes=False``: take every listed node
    as alive (one call to the master, not one to each node)."""
    master = master_proxy(uri)
    reply: Any = master.getSystemState(CALLER)
    code, message, state = reply
    if code != 1:
        raise OSError(f"the ROS master refused getSystemState: {message}")
    publishes: dict[str, set[str]] = defaultdict(set)
    subscribes: dict[str, set[str]] = defaultdict(set)
    services: dict[str, set[str]] = defaultdict(set)
    for table, into in zip(state, (publishes, subscribes, services), strict=True):
        for name, nodes in table:
            for node in nodes:
                into[node.lstrip("/")].add(name)
    names = sorted({*publishes, *subscribes, *services})

    def lookup(name: str) -> bool:
        try:
            found: Any = master_proxy(uri).lookupNode(CALLER, "/" + name)
            code, _, node_uri = found
        except UNREACHABLE:
            return False
        return code == 1 and _answers(node_uri)

    if ask_nodes:
        with ThreadPoolExecutor(max_workers=8) as pool:
            alive = dict(zip(names, pool.map(lookup, names), strict=True))
    else:
        alive = dict.fromkeys(names, True)
    return GraphView(
        {
            name: GraphNode(
                name,
                frozenset(publishes[name]),
                frozenset(subscribes[name]),
                frozenset(services[name]),
                alive[name],
            )
            for name in names
        }
    )
