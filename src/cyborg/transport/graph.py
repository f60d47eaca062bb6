"""What a ROS graph holds at one moment: its nodes and what each publishes, subscribes and serves.

``cyborg doctor`` compares it with what a configuration needs. The ROS transports make it
(:meth:`cyborg.transport.ros.RosTransport.graph`: the master's state; the ROS 2 transport: DDS
discovery); node names have no leading slash, topic and service names have one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["GraphNode", "GraphView"]


@dataclass(frozen=True)
class GraphNode:
    """One node of the graph; ``alive`` is False for a node still listed that does not answer
    (ROS 1: killed without unregistering)."""

    name: str
    publishes: frozenset[str] = frozenset()
    subscribes: frozenset[str] = frozenset()
    services: frozenset[str] = frozenset()
    alive: bool = True


@dataclass(frozen=True)
class GraphView:
    """The nodes of a graph by name."""

    nodes: dict[str, GraphNode] = field(default_factory=dict)

    def publishers_of(self, topic: str) -> list[str]:
        return sorted(n.name for n in self.nodes.values() if topic in n.publishes)

    def subscribers_of(self, topic: str) -> list[str]:
        return sorted(n.name for n in self.nodes.values() if topic in n.subscribes)

    def servers_of(self, service: str) -> list[str]:
        return sorted(n.name for n in self.nodes.values() if service in n.services)

    def alive(self, name: str) -> bool:
        node = self.nodes.get(name)
        return node is not None and node.alive
