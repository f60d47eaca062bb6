"""Conversion between our message dataclasses and the generated ROS 2 (rosidl) classes.

Part of the ROS 2 transport (:mod:`cyborg.transport.ros2`). Our messages name their ROS 1 type
(``std_msgs/String``, ``cyborg_controller/StateMachineAction``); :func:`ros2_class` finds the
ROS 2 class of the same package and name (``std_msgs.msg.String``,
``cyborg_controller.action.StateMachine``). Fields are copied by name with the walk both ROS
transports share (:mod:`cyborg.transport._convert`); a ROS 1 time (float seconds) becomes a
``builtin_interfaces/Time`` and back, and ``std_msgs/Header``'s ``seq`` (gone in ROS 2) is left out.
"""

from __future__ import annotations

import importlib
from typing import Any

from cyborg.errors import TransportError
from cyborg.transport._convert import fields_from, fields_to
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
    return fields_to(message, cls, _value_out)


def _value_out(value: Any, current: Any) -> Any:
    if _is_time(current):
        seconds = max(0.0, float(value))
        stamp = type(current)()
        stamp.sec = int(seconds)
        stamp.nanosec = round((seconds - int(seconds)) * 1e9) % 1_000_000_000
        return stamp
    if isinstance(value, tuple):
        return list(value)
    return value


def from_ros2(ros_message: Any, cls: type[M]) -> M:
    """A ROS 2 message as our dataclass ``cls`` (fields the ROS 2 message lacks keep their defaults)."""
    return fields_from(ros_message, cls, _value_in)


def _value_in(value: Any) -> Any:
    if _is_time(value):
        return value.sec + value.nanosec / 1e9
    if hasattr(value, "tolist"):
        return tuple(value.tolist())  # numpy arrays (float64[36] covariance)
    if isinstance(value, list):
        return tuple(value)
    return value
