"""The idle module: boredom while active, and an immediate stop when preempted."""

from __future__ import annotations

from cyborg.modules.idle import KIND
from cyborg.testing import GoalStatus, ModuleHarness


def test_idle_sends_boredom_and_stops_at_once_when_preempted() -> None:
    with ModuleHarness(
        KIND, {"interval": 2.0, "boredom": [-0.1, -0.2, -0.05]}, node_name="cyborg_idle"
    ) as idle:
        goal = idle.start("cyborg_idle/idle", event="start")
        idle.run(7.0)
        goal.cancel()
        idle.run(0.001)
        assert goal.status is GoalStatus.PREEMPTED, "the preemption is acknowledged at once"
        idle.run(10.0)
    assert [round(f.t - idle.feedback[0].t) for f in idle.feedback] == [0, 2, 4]  # nothing after it
    assert idle.feedback[0].pad == (-0.1, -0.2, -0.05)
    assert idle.said == [] and idle.events == []


def test_idle_refuses_a_non_positive_interval_naming_the_setting() -> None:
    import pytest

    from cyborg.errors import ConfigError

    with pytest.raises(ConfigError, match=r"interval: .*greater than 0"):
        ModuleHarness(KIND, {"interval": 0})
