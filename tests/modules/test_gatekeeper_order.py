"""A module's first sentence in its state may reach the gatekeeper before the state change does
(over ROS 2 nothing orders messages of two nodes): the gatekeeper reads /state_resources again
and passes it, since the controller set them before it sent the goal. A sender the resources do
not name stays dropped, and its flood costs one read per state, not one per message."""

from __future__ import annotations

from typing import Any

from cyborg.transport import topics
from cyborg.transport.clock import VirtualClock
from cyborg.transport.messages import String, SystemState
from tests.modules.test_gatekeeper_speech import build


def test_the_holders_first_sentence_passes_before_its_state_change_arrives(clock: VirtualClock) -> None:
    transport, gate, heard = build(clock)
    controller = transport.node("cyborg_controller")
    change = controller.publisher(topics.STATE_CHANGE, SystemState, latch=True)
    talker = transport.node("talker_b").publisher(topics.TEXT_TO_SPEECH, String)
    intruder = transport.node("intruder").publisher(topics.TEXT_TO_SPEECH, String)
    reads = 0
    read = gate.node.get_param

    def get_param(name: str, default: Any = None) -> Any:
        nonlocal reads
        reads += 1
        return read(name, default)

    gate.node.get_param = get_param  # type: ignore[method-assign]

    async def main() -> None:
        controller.set_param(topics.STATE_RESOURCES_PARAM, {"speech": "talker_a"})
        change.publish(SystemState("", "start", "idle"))
        await clock.sleep(1.0)
        before = reads
        # The controller switches: resources first, then (late) its state change.
        controller.set_param(topics.STATE_RESOURCES_PARAM, {"speech": "talker_b"})
        talker.publish(String("I hold speech now"))
        for _ in range(50):
            intruder.publish(String("me too"))
        await clock.sleep(1.0)
        assert reads - before == 2  # one for talker_b, one for the intruder's whole flood
        change.publish(SystemState("idle", "switch", "other"))
        await clock.sleep(1.0)
        talker.publish(String("still me"))
        await clock.sleep(1.0)

    clock.run(main())
    assert [text for _, text in heard] == ["I hold speech now", "still me"]
    assert gate.stats.dropped_by_sender["intruder"] == 50
    assert gate.report()["held_by"] == "talker_b"
