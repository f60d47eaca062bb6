"""The idle module: boredom while active, and an immediate stop when preempted."""

from __future__ import annotations

from cyborg.modules.idle import IdleModule, IdleSettings
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, MessageInfo
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import EmotionalFeedback, StateMachineAction, StateMachineGoal


def test_idle_sends_boredom_and_stops_at_once_when_preempted(clock: VirtualClock) -> None:
    transport = EmbeddedTransport(clock)
    IdleModule(transport.node("cyborg_idle"), IdleSettings(interval=2.0, boredom=(-0.1, -0.2, -0.05)))
    probe = transport.node("probe")
    feedback: list[tuple[float, EmotionalFeedback]] = []

    def on_feedback(m: EmotionalFeedback, info: MessageInfo) -> None:
        feedback.append((clock.monotonic(), m))

    probe.subscribe(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback, on_feedback)
    client = probe.action_client("cyborg_idle/idle", StateMachineAction)

    async def main() -> tuple[GoalStatus, float]:
        handle = client.send_goal(StateMachineGoal("", "start", "idle"))
        await clock.sleep(7.0)
        cancelled_at = clock.monotonic()
        handle.cancel()
        status = await handle.wait()
        waited = clock.monotonic() - cancelled_at
        await clock.sleep(10.0)
        return status, waited

    status, waited = clock.run(main())
    assert status is GoalStatus.PREEMPTED
    assert waited < 0.01
    assert [round(t) for t, _ in feedback] == [2, 4, 6]  # nothing after the preemption
    assert (feedback[0][1].delta_pleasure, feedback[0][1].delta_arousal) == (-0.1, -0.2)
