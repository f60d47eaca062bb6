"""Embedded-transport behaviour beyond the shared contract: waiting for an offer is event-driven."""

from __future__ import annotations

import pytest

from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import EmotionalStateService, EmotionalStateServiceResponse, StateMachineAction


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

    assert clock.run(main()) == (False, pytest.approx(1.5))
