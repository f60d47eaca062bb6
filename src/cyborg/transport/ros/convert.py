"""Conversion between our message dataclasses and the generated ROS 1 (genpy) classes.

Part of the ROS 1 transport (:mod:`cyborg.transport.ros`): its topics, services and actions
convert every message field by field on the way out (:func:`to_ros`) and in (:func:`from_ros`),
with the walk both ROS transports share (:mod:`cyborg.transport._convert`); the names are the
same by design. :func:`sender` reads who sent a received message.
"""

from __future__ import annotations

import importlib
from typing import Any

import genpy  # type: ignore[import-not-found]
import rospy  # type: ignore[import-not-found]

from cyborg.errors import TransportError
from cyborg.transport._convert import fields_from, fields_to
from cyborg.transport.base import M, normalize_node_name
from cyborg.transport.messages import Message

__all__ = ["from_ros", "ros_class", "sender", "to_ros"]


def ros_class(ros_type: str, kind: str = "msg") -> Any:
    """The generated ROS class for ``pkg/Name`` (``kind`` msg or srv)."""
    package, _, name = ros_type.partition("/")
    try:
        return getattr(importlib.import_module(f"{package}.{kind}"), name)
    except (ImportError, AttributeError) as exc:
        raise TransportError(
            f"ROS type {ros_type} is not importable ({exc}); fix: source .venv/bin/activate after "
            "scripts/install-ros, which generates this project's messages"
        ) from exc


def to_ros(message: Message, cls: Any) -> Any:
    """``message`` as an instance of the ROS class ``cls`` (fields ``cls`` lacks are left out)."""
    return fields_to(message, cls, _value_out)


def _value_out(value: Any, current: Any) -> Any:
    if isinstance(current, genpy.Time):
        return rospy.Time.from_sec(max(0.0, float(value)))
    return value


def from_ros(ros_message: Any, cls: type[M]) -> M:
    """A ROS message as our dataclass ``cls`` (fields the ROS message lacks keep their defaults)."""
    return fields_from(ros_message, cls, _value_in)


def _value_in(value: Any) -> Any:
    if hasattr(value, "to_sec"):
        return value.to_sec()
    if isinstance(value, tuple):
        return tuple(value)  # messages are frozen: tuples, not lists
    return value


def sender(ros_message: Any) -> str:
    """The node that sent a received message (its connection header's caller id), or ''."""
    header = getattr(ros_message, "_connection_header", None) or {}
    return normalize_node_name(str(header.get("callerid", "")))
