"""What a ROS graph holds at one moment: its nodes and what each publishes, subscribes and serves.

``cyborg doctor`` compares it with what a configuration needs. The ROS transports make it
(:meth:`cyborg.transport.ros.RosTransport.graph`: the master's state; the ROS 2 transport: DDS
discovery); node names have no leading slash, topic and service names have one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["GraphNode", "GraphView", "acting_nodes"]


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


_ROS_OWN_TOPICS = frozenset({"/rosout", "/parameter_events"})
_ROS_OWN_SERVICE_ENDS = (
    "/get_loggers",
    "/set_logger_level",
    "/describe_parameters",
    "/get_parameters",
    "/get_parameter_types",
    "/list_parameters",
    "/set_parameters",
    "/set_parameters_atomically",
    "/get_type_description",
    "/get_logger_levels",
    "/set_logger_levels",
)


def acting_nodes(view: GraphView) -> list[str]:
    """The nodes of ``view`` that publish or serve something of their own (not only ROS's own
    log, parameter and logger endpoints): a node that only listens changes nothing."""
    return sorted(
        node.name
        for node in view.nodes.values()
        if node.publishes - _ROS_OWN_TOPICS
        or any(not service.endswith(_ROS_OWN_SERVICE_ENDS) for service in node.services)
    )
