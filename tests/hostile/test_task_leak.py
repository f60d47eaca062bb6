"""Issue 31, "Also": a module that leaks tasks is named, in a few lines, before it eats the robot.

The attack of the review (11.9): a plugin whose timer starts a never-ending task every few
milliseconds grew the robot by about 1 MB/s without a word. Here the in-process robot of
``cyborg sim`` (:func:`cyborg.run.local.run_sim`, virtual time as fast as possible) runs such a
component beside its modules for a virtual minute: the log names this module, its count and the
fix, and says it again only as the count doubles.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest

from cyborg.app.config import load_config
from cyborg.app.robot import Robot
from cyborg.run.local import run_sim
from cyborg.transport.base import Transport

CONFIG = Path(__file__).resolve().parent / "graph_robot.yaml"


async def never_ending() -> None:
    await asyncio.Event().wait()


async def leak_beside(transport: Transport, robot: Robot) -> Callable[[], Awaitable[None]]:
    """A careless module: every 20 ms of the robot's clock a task it never ends (and keeps no handle of)."""
    clock = transport.clock
    kept: list[asyncio.Task[None]] = []  # only so that the test ends them; the module "forgot" them
    timer = clock.every(0.02, lambda: kept.append(clock.loop.create_task(never_ending())), name="leak")

    async def stop() -> None:
        timer.cancel()
        for task in kept:
            task.cancel()
        await asyncio.gather(*kept, return_exceptions=True)

    return stop


def test_a_module_leaking_tasks_is_named_with_the_fix_in_a_few_lines(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING):
        run_sim(
            load_config(CONFIG),
            speed=None,
            duration=60.0,
            echo=lambda text: None,
            serve=leak_beside,
            data_dir=tmp_path / "data",
        )
    named = [r.getMessage() for r in caplog.records if __name__ in r.getMessage()]
    assert named, "no warning named the module that leaks tasks"
    assert "tasks pending" in named[0] and "never_ending" in named[0] and "fix:" in named[0], named[0]
    assert 1 <= len(named) <= 2, named  # ~3,000 tasks: at 1,000, then at 2,000 at the most
