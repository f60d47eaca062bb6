"""Other nodes' warnings and errors on a ROS graph, for the flight recorder of a launch.

Every ROS node logs to ``/rosout``: on ROS 1 the ``rosout`` node gathers them on
``/rosout_agg`` (``rosgraph_msgs/Log``; what rqt_console reads), on ROS 2 each node publishes
``/rosout`` itself (``rcl_interfaces/msg/Log``). :func:`hear_ros_logs` subscribes the recorder's
node to the one of its middleware and hands each warning, error and fatal message, except the
recorder's own (its warnings reach the file by the logging handler), to
:meth:`~cyborg.observe.recorder.Recorder.node_log`: a line of Foxglove's Log panel with the
node's name, and a ``rosout`` entry of the diagnostics channel with the file, function and line.
Information and debug messages are left out: a launch's nodes say a lot that nobody looks back for.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

from cyborg.transport.base import MessageInfo, normalize_node_name
from cyborg.transport.messages import Header, Message

if TYPE_CHECKING:
    from cyborg.observe.recorder import Recorder

__all__ = ["ROS_LOGS", "Ros1Log", "Ros2Log", "RosLogSource", "hear_ros_logs"]


@dataclass(frozen=True)
class Ros1Log(Message):
    """``rosgraph_msgs/Log`` (levels DEBUG 1, INFO 2, WARN 4, ERROR 8, FATAL 16)."""

    ros_type: ClassVar[str] = "rosgraph_msgs/Log"
    header: Header = field(default_factory=Header)
    level: int = 0
    name: str = ""
    msg: str = ""
    file: str = ""
    function: str = ""
    line: int = 0


@dataclass(frozen=True)
class Ros2Log(Message):
    """``rcl_interfaces/msg/Log`` (levels DEBUG 10, INFO 20, WARN 30, ERROR 40, FATAL 50)."""

    ros_type: ClassVar[str] = "rcl_interfaces/Log"
    stamp: float = 0.0
    level: int = 0
    name: str = ""
    msg: str = ""
    file: str = ""
    function: str = ""
    line: int = 0


@dataclass(frozen=True)
class RosLogSource:
    """Where a middleware's log messages are heard, and which of their levels are recorded."""

    topic: str
    message_type: type[Ros1Log] | type[Ros2Log]
    levels: dict[int, str]
    """Level number -> ``warning``, ``error`` or ``fatal`` (others are not recorded)."""


ROS_LOGS: dict[str, RosLogSource] = {
    "ROS 1": RosLogSource("/rosout_agg", Ros1Log, {4: "warning", 8: "error", 16: "fatal"}),
    "ROS 2": RosLogSource("/rosout", Ros2Log, {30: "warning", 40: "error", 50: "fatal"}),
}
"""By middleware name (:attr:`cyborg.run.middleware.Middleware.name`)."""

LOG_TEXT_LIMIT = 2000
"""Characters of a log message kept (a node that logs a whole file is cut there)."""


def hear_ros_logs(recorder: Recorder, middleware: str) -> RosLogSource | None:
    """Record the warnings and errors of every other node on the graph (None: ``middleware`` has
    no ``/rosout`` this code knows, e.g. one process)."""
    source = ROS_LOGS.get(middleware)
    if source is None:
        return None
    own = normalize_node_name(recorder.node.name)

    def on_log(message: Ros1Log | Ros2Log, info: MessageInfo) -> None:
        level = source.levels.get(message.level)
        if level is None or normalize_node_name(message.name or info.sender) == own:
            return
        recorder.node_log(
            node=normalize_node_name(message.name or info.sender),
            level=level,
            text=message.msg[:LOG_TEXT_LIMIT],
            where={"file": message.file, "function": message.function, "line": message.line},
        )

    ledger = recorder.node.clock.ledger
    if ledger is not None:
        # Lockstep: every node logs outside the transport's counts; counted, each warning would be a
        # surplus from outside, and the time would slow down for a while after it.
        ledger.ignore(source.topic)
    recorder.node.subscribe(source.topic, source.message_type, on_log, queue_size=1000)
    return source
