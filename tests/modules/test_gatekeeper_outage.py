"""A gatekeeper that cannot read /state_resources (over ROS: the master is away) passes nothing and
reads them again until it can: then the module in control gets through (issue 12, item 3)."""

from __future__ import annotations

from typing import Any

from cyborg.app.config import parse_config
from cyborg.controller.runtime import Controller
from cyborg.errors import TransportError
from cyborg.modules.gatekeeper import READ_RETRY
from cyborg.transport import topics
from cyborg.transport.clock import VirtualClock
from cyborg.transport.messages import String
from tests.modules.test_gatekeeper_speech import MACHINE, Talker, build


def test_a_gatekeeper_that_cannot_read_the_resources_passes_nothing_until_it_can(
    clock: VirtualClock,
) -> None:
    transport, gate, heard = build(clock)
    Talker(transport, "talker_a")
    Talker(transport, "talker_b")
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)
    switch = transport.node("switcher").publisher(topics.REGISTER_EVENT, String)
    away = False
    read = gate.node.get_param

    def get_param(name: str, default: Any = None) -> Any:
        if away:
            raise TransportError("the ROS master does not answer")
        return read(name, default)

    gate.node.get_param = get_param  # type: ignore[method-assign]
    params: dict[str, Any] = transport._params
    controller.start()

    async def main() -> None:
        nonlocal away
        await clock.sleep(3.2)  # idle: talker_a holds speech
        away = True
        switch.publish(String("switch"))  # other: talker_b holds speech, but the gate cannot tell
        await clock.sleep(3.0)
        away = False  # back, but (a restarted master) without the resources yet
        resources = params.pop(topics.STATE_RESOURCES_PARAM)
        await clock.sleep(2.0)
        params[topics.STATE_RESOURCES_PARAM] = resources  # the controller set them again
        await clock.sleep(3.0)

    clock.run(main())
    assert {text for t, text in heard if t < 3.2} == {"talker_a speaking"}
    assert [text for t, text in heard if 3.2 < t < 8.2] == []
    after = [text for t, text in heard if t > 8.2 + READ_RETRY]
    assert after and set(after) == {"talker_b speaking"}
    assert gate.report()["held_by"] == "talker_b"
