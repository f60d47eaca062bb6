"""Embedded-transport behaviour beyond the shared contract: waiting for an offer is event-driven;
messages are shared when frozen and copied for each subscriber when not."""

from __future__ import annotations

import asyncio
import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import pytest

from cyborg.transport import messages
from cyborg.transport.base import MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import (
    EmotionalStateService,
    EmotionalStateServiceResponse,
    Message,
    Point,
    Pose,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    StateMachineAction,
    is_immutable,
)


@pytest.mark.parametrize("kind", ["action", "service"])
def test_a_waiter_wakes_the_moment_the_server_appears(clock: VirtualClock, kind: str) -> None:
    transport = EmbeddedTransport(clock)
    user = transport.node("user")
    client = user.action_client("/later/run", StateMachineAction)
    proxy = user.service_proxy("/later/ask", EmotionalStateService)

    def offer() -> None:
        node = transport.node("later")
        if kind == "action":
            node.action_server(
                "/later/run", StateMachineAction, lambda handle: handle.accept(), lambda h: None
            )
        else:
            node.advertise_service(
                "/later/ask", EmotionalStateService, lambda r, i: EmotionalStateServiceResponse()
            )

    async def main() -> tuple[bool, float]:
        clock.call_later(0.013, offer)
        waited = client.wait_for_server(2.0) if kind == "action" else proxy.wait_for_service(2.0)
        found = await waited
        return found, clock.monotonic()

    found, at = clock.run(main())
    assert found and at == pytest.approx(0.013, abs=1e-9)  # not at the next tick of a polling loop


def test_a_waiter_gives_up_at_its_timeout(clock: VirtualClock) -> None:
    client = EmbeddedTransport(clock).node("user").action_client("/nobody/run", StateMachineAction)

    async def main() -> tuple[bool, float]:
        return await client.wait_for_server(1.5), clock.monotonic()

    found, at = clock.run(main())
    assert found is False and at == pytest.approx(1.5)


@dataclass(frozen=True)
class _Scores(Message):
    """A message type with a mutable field (a list): the transport must copy it for each subscriber."""

    ros_type: ClassVar[str] = "test_msgs/Scores"
    values: list[int] = field(default_factory=list)


def test_every_packaged_message_is_frozen_and_shared_without_a_copy(clock: VirtualClock) -> None:
    kinds = [c for c in vars(messages).values() if isinstance(c, type) and issubclass(c, Message)]
    assert len(kinds) > 20 and all(is_immutable(kind) for kind in kinds)
    transport = EmbeddedTransport(clock)
    got: dict[str, PoseWithCovarianceStamped] = {}

    def keep(name: str) -> Callable[[PoseWithCovarianceStamped, MessageInfo], None]:
        return lambda message, info: got.__setitem__(name, message)

    for name in ("a", "b"):
        transport.node(name).subscribe("/pose", PoseWithCovarianceStamped, keep(name))
    sent = PoseWithCovarianceStamped(pose=PoseWithCovariance(Pose(Point(1.0, 2.0, 0.0))))
    transport.node("base").publisher("/pose", PoseWithCovarianceStamped).publish(sent)
    clock.run(asyncio.sleep(0.001))  # taken in the next delta cycle, once this instant's work is done
    assert got["a"] is sent and got["b"] is sent  # no copy
    with pytest.raises(dataclasses.FrozenInstanceError):
        got["a"].pose.pose.position.x = 5.0  # type: ignore[misc]
    assert got["b"].pose.pose.position.x == 1.0


def test_a_subscriber_cannot_change_what_another_received_nor_what_was_sent(clock: VirtualClock) -> None:
    transport = EmbeddedTransport(clock)
    got: dict[str, list[int]] = {}

    def spoil(message: _Scores, info: MessageInfo) -> None:
        message.values.append(666)  # a careless subscriber changes its message
        got["spoiler"] = message.values

    def keep(message: _Scores, info: MessageInfo) -> None:
        got["keeper"] = message.values

    transport.node("spoiler").subscribe("/scores", _Scores, spoil)
    transport.node("keeper").subscribe("/scores", _Scores, keep)
    sent = _Scores([1, 2])
    transport.node("judge").publisher("/scores", _Scores, latch=True).publish(sent)
    sent.values.append(3)  # and the publisher reuses its object after publishing
    clock.run(asyncio.sleep(0.001))
    assert got == {"spoiler": [1, 2, 666], "keeper": [1, 2]}
    assert sent.values == [1, 2, 3]
    late: list[list[int]] = []
    transport.node("late").subscribe("/scores", _Scores, lambda m, i: late.append(m.values))
    clock.run(asyncio.sleep(0.001))
    assert late == [[1, 2]]  # the latched message is what was sent, not what anyone made of it
