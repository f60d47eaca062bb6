"""Conversion between our message dataclasses and the generated ROS 2 (rosidl) classes.

Part of the ROS 2 transport (:mod:`cyborg.transport.ros2`). Our messages name their ROS 1 type
(``std_msgs/String``, ``cyborg_controller/StateMachineAction``); :func:`ros2_class` finds the
ROS 2 class of the same package and name (``std_msgs.msg.String``,
``cyborg_controller.action.StateMachine``). Fields are copied by name, as for ROS 1; a ROS 1
time (float seconds) becomes a ``builtin_interfaces/Time`` and back, and ``std_msgs/Header``'s
``seq`` (gone in ROS 2) is left out.
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import Any

from cyborg.errors import TransportError
from cyborg.transport.base import M
from cyborg.transport.messages import Message

__all__ = ["from_ros2", "ros2_class", "ros2_type_name", "to_ros2"]


def ros2_class(ros_type: str, kind: str = "msg") -> Any:
    """The ROS 2 class for ``pkg/Name`` (``kind`` msg, srv or action; an action's ``Action``
    suffix is dropped: ``cyborg_controller/StateMachineAction`` -> ``cyborg_controller.action.StateMachine``)."""
    package, _, name = ros_type.partition("/")
    if kind == "action" and name.endswith("Action"):
        name = name[: -len("Action")]
    try:
        return getattr(importlib.import_module(f"{package}.{kind}"), name)
    except (ImportError, AttributeError) as exc:
        raise TransportError(
            f"ROS 2 type {package}/{kind}/{name} is not importable ({exc}); fix: run scripts/install-ros2 "
            "and use .venv-ros2/bin/python, which has the ROS 2 wheels and our interfaces"
        ) from exc


def ros2_type_name(cls: Any) -> str:
    """``std_msgs/msg/String`` for the class ``std_msgs.msg.String``."""
    module = cls.__module__.split(".")
    return f"{module[0]}/{module[1]}/{cls.__name__}"


def _is_time(value: Any) -> bool:
    return type(value).__name__ in ("Time", "Duration") and hasattr(value, "nanosec")


def to_ros2(message: Message, cls: Any) -> Any:
    """``message`` as an instance of the ROS 2 class ``cls`` (fields ``cls`` lacks are left out)."""
    out = cls()
    for field in dataclasses.fields(message):
        value = getattr(message, field.name)
        if not hasattr(out, field.name):
            continue
        current = getattr(out, field.name)
        if isinstance(value, Message):
            setattr(out, field.name, to_ros2(value, type(current)))
        elif _is_time(current):
            seconds = max(0.0, float(value))
            stamp = type(current)()
            stamp.sec = int(seconds)
            stamp.nanosec = round((seconds - int(seconds)) * 1e9) % 1_000_000_000
            setattr(out, field.name, stamp)
        elif isinstance(value, tuple):
            setattr(out, field.name, list(value))
        else:
            setattr(out, field.name, value)
    return out


def from_ros2(ros_message: Any, cls: type[M]) -> M:
    """A ROS 2 message as our dataclass ``cls`` (fields the ROS 2 message lacks keep their defaults)."""
    values: dict[str, Any] = {}
    for field in dataclasses.fields(cls):
        if not hasattr(ros_message, field.name):
            continue
        value = getattr(ros_message, field.name)
        default = field.default_factory() if field.default_factory is not dataclasses.MISSING else None
        if isinstance(default, Message):
            values[field.name] = from_ros2(value, type(default))
        elif _is_time(value):
            values[field.name] = value.sec + value.nanosec / 1e9
        elif hasattr(value, "tolist"):
            values[field.name] = tuple(value.tolist())  # numpy arrays (float64[36] covariance)
        elif isinstance(value, list):
            values[field.name] = tuple(value)
        else:
            values[field.name] = value
    return cls(**values)
