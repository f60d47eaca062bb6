"""A module reads the robot's clock with self.now() / ctx.now(); the harness starts it where told."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone
from zoneinfo import ZoneInfo

from cyborg.modules import BehaviourModule, GoalContext, Node
from cyborg.testing import ModuleHarness


class TimeTeller(BehaviourModule):
    def __init__(self, node: Node) -> None:
        super().__init__(node)
        self.told: list[datetime] = []
        self.serve("time_teller/tell", self.tell)

    async def tell(self, ctx: GoalContext) -> None:
        self.told.append(ctx.now())
        self.say(f"It is {ctx.now().astimezone(ZoneInfo('Europe/Oslo')):%H:%M}.")
        await ctx.sleep(2)


def test_a_module_reads_the_harness_clock_which_starts_where_told() -> None:
    start = datetime(2026, 11, 23, 15, 29, tzinfo=timezone(timedelta(hours=1)))
    with ModuleHarness(TimeTeller, start=start) as robot:
        module = robot.module
        assert isinstance(module, TimeTeller)
        assert module.now() == start and module.now().tzinfo is UTC
        robot.run(90)
        robot.start()
        assert module.told == [start + timedelta(seconds=90)]
        assert robot.said == ["It is 15:30."]


def test_a_naive_harness_start_is_utc_and_the_default_is_documented() -> None:
    with ModuleHarness(TimeTeller, start=datetime(2026, 6, 1, 12, 0)) as robot:
        assert isinstance(robot.module, TimeTeller)
        assert robot.module.now() == datetime(2026, 6, 1, 12, 0, tzinfo=UTC)
    with ModuleHarness(TimeTeller) as robot:
        assert isinstance(robot.module, TimeTeller)
        assert robot.module.now() == datetime(2026, 11, 23, 9, 0, tzinfo=UTC)
