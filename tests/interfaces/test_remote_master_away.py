"""The API node's mirror of the emotion switch while the ROS master is away (issue 12, item 3):
unknown (None) instead of an error, so the status is still served."""

from __future__ import annotations

from typing import Any

from cyborg.errors import TransportError
from cyborg.transport import topics
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.web.ros_view import EmotionSwitchMirror


def test_the_switch_reads_as_unknown_while_the_master_is_away(clock: VirtualClock) -> None:
    transport = EmbeddedTransport(clock)
    node = transport.node("cyborg_api")
    node.set_param(topics.EMOTION_ENABLED_PARAM, False)
    mirror = EmotionSwitchMirror(node)
    assert mirror.enabled is False

    def away(name: str, default: Any = None) -> Any:
        raise TransportError("could not read the parameter: the ROS master does not answer")

    node.get_param = away  # type: ignore[method-assign]
    assert mirror.enabled is None
