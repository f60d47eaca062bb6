"""The field-by-field walk between our message dataclasses and generated ROS classes.

Shared by :mod:`cyborg.transport.ros.convert` and :mod:`cyborg.transport.ros2.convert`: the
field names are the same by design, nested messages are walked the same way, and each ROS
version says only how one plain value crosses (a time, a list). Nothing here imports ROS.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from cyborg.transport.base import M
from cyborg.transport.messages import Message

__all__ = ["fields_from", "fields_to"]


def fields_to(message: Message, cls: Any, value_out: Callable[[Any, Any], Any]) -> Any:
    """``message`` as an instance of the ROS class ``cls`` (fields ``cls`` lacks are left out).

    A nested message is walked; any other field becomes ``value_out(value, cls's default)``.
    """
    out = cls()
    for field in dataclasses.fields(message):
        value = getattr(message, field.name)
        if not hasattr(out, field.name):
            continue
        current = getattr(out, field.name)
        if isinstance(value, Message):
            setattr(out, field.name, fields_to(value, type(current), value_out))
        else:
            setattr(out, field.name, value_out(value, current))
    return out


def fields_from(ros_message: Any, cls: type[M], value_in: Callable[[Any], Any]) -> M:
    """A ROS message as our dataclass ``cls`` (fields the ROS message lacks keep their defaults).

    A field whose default is a message is walked; any other becomes ``value_in(ros value)``.
    """
    values: dict[str, Any] = {}
    for field in dataclasses.fields(cls):
        if not hasattr(ros_message, field.name):
            continue
        value = getattr(ros_message, field.name)
        default = field.default_factory() if field.default_factory is not dataclasses.MISSING else None
        if isinstance(default, Message):
            values[field.name] = fields_from(value, type(default), value_in)
        else:
            values[field.name] = value_in(value)
    return cls(**values)
